// touchmend — command line for automated clients and batch repair of triangle meshes.

#include <iostream>

#include <CLI/CLI.hpp>
#include <OpenMesh/Core/System/omstream.hh>

#include "client/cli/commands.h"

int main(int argc, char** argv) {
  // OpenMesh reports refused faces on its own error stream; touchmend reports them itself.
  omerr().disable();
  omout().disable();
  omlog().disable();

  using namespace touchmend::cli;
  CLI::App app{
      "touchmend repairs triangle meshes from reverse engineering: it finds the holes of a scanned "
      "mesh and\n"
      "fills the ones you choose (seed 000 Algorithms I-III, piecewise filling of complex holes), "
      "leaving\n"
      "functional holes alone. Formats: STL (ASCII/binary), OBJ, OFF, PLY (ASCII/binary).\n\n"
      "With --server HOST:PORT, holes and fill run on a touchmend-server (through a temporary\n"
      "session), and `job` submits and manages fill jobs there.\n\n"
      "Exit codes: 0 done, 1 bad input (the message names the problem), 2 usage,\n"
      "3 some selected holes were left open (only with fill --strict), 4 server unreachable,\n"
      "refused the token, or failed."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "touchmend 0.1.0");

  RemoteArgs remote;
  app.add_option("--server", remote.server,
                 "Run on this touchmend-server (HOST:PORT) instead of in-process");
  app.add_option(
      "--token", remote.token,
      "Bearer token for --server (default: $TOUCHMEND_TOKEN; visible in ps, so prefer it)");
  app.add_option("--tls-ca", remote.tls_ca,
                 "Connect with TLS, verifying the server with this CA file");
  app.add_flag("--tls", remote.tls, "Connect with TLS, verifying the server with the system's CAs");

  InfoArgs info;
  auto* info_cmd =
      app.add_subcommand("info",
                         "Counts, bounds and a validation report (non-manifold edges and\n"
                         "vertices, degenerate, duplicate, flipped and refused faces)");
  info_cmd->add_option("FILE", info.file, "Mesh file")->required();
  info_cmd->add_flag("--json", info.json, "Print JSON instead of text");

  HolesArgs holes;
  auto* holes_cmd =
      app.add_subcommand("holes",
                         "List the holes: stable id (smallest boundary vertex index),\n"
                         "boundary edges, perimeter, area, centroid, normal, simple/complex");
  holes_cmd->add_option("FILE", holes.file, "Mesh file")->required();
  holes_cmd->add_flag("--json", holes.json,
                      "Print JSON instead of text (includes each hole's vertex loop)");

  FillArgs fill;
  std::string near_text;
  auto* fill_cmd =
      app.add_subcommand("fill",
                         "Fill holes and write the repaired mesh (atomically: a temporary\n"
                         "file renamed over OUT, so OUT is never half-written)");
  fill_cmd->add_option("FILE", fill.file, "Mesh file with holes")->required();
  fill_cmd
      ->add_option("-o,--output", fill.output,
                   "Where to write the repaired mesh (.stl .obj .off .ply)")
      ->required();
  auto* all_opt = fill_cmd->add_flag("--all", fill.all, "Fill every hole (up to --max-boundary)");
  auto* hole_opt = fill_cmd->add_option("--hole", fill.hole_ids,
                                        "Fill the holes with these ids (see `touchmend holes`)");
  auto* near_opt = fill_cmd->add_option("--near", near_text,
                                        "Fill the hole whose boundary passes closest to X,Y,Z");
  all_opt->excludes(hole_opt)->excludes(near_opt);
  hole_opt->excludes(near_opt);
  fill_cmd
      ->add_option("--max-boundary", fill.max_boundary,
                   "Skip holes with more boundary edges than this (0 = no limit); large holes are\n"
                   "often functional openings")
      ->check(CLI::NonNegativeNumber);
  fill_cmd
      ->add_option("--refine-iterations", fill.refine_iterations,
                   "Rounds of Liepa refinement (seed 000 §3.4.4 suggests 1-5)")
      ->check(CLI::Range(1, 5))
      ->capture_default_str();
  fill_cmd
      ->add_option(
          "--shape", fill.shape,
          "flat: keep the refined triangulation; fair: bi-Laplacian fairing that continues\n"
          "the surrounding surface; auto: flat where the surroundings are planar, else fair")
      ->check(CLI::IsMember({"flat", "fair", "auto"}))
      ->capture_default_str();
  fill_cmd->add_flag("--json", fill.json, "Print the fill report as JSON");
  fill_cmd->add_flag("--binary", fill.binary, "Write binary PLY (doubles) or binary STL (floats)");
  fill_cmd->add_flag("--strict", fill.strict, "Exit with 3 when a selected hole is left open");

  JobArgs job;
  std::string job_near_text;
  auto* job_cmd = app.add_subcommand(
      "job", "Fill jobs on a server (needs --server): submit, status, wait, cancel, fetch, list");
  job_cmd->require_subcommand(1);
  auto* submit_cmd = job_cmd->add_subcommand(
      "submit", "Submit FILE as a fill job; prints the job id (or waits with --wait)");
  submit_cmd->add_option("FILE", job.fill.file, "Mesh file with holes")->required();
  auto* job_all =
      submit_cmd->add_flag("--all", job.fill.all, "Fill every hole (up to --max-boundary)");
  auto* job_holes =
      submit_cmd->add_option("--hole", job.fill.hole_ids, "Fill the holes with these ids");
  auto* job_near = submit_cmd->add_option("--near", job_near_text, "Fill the hole nearest X,Y,Z");
  job_all->excludes(job_holes)->excludes(job_near);
  job_holes->excludes(job_near);
  submit_cmd
      ->add_option("--max-boundary", job.fill.max_boundary, "Skip holes with more boundary edges")
      ->check(CLI::NonNegativeNumber);
  submit_cmd
      ->add_option("--refine-iterations", job.fill.refine_iterations, "Rounds of Liepa refinement")
      ->check(CLI::Range(1, 5))
      ->capture_default_str();
  submit_cmd->add_option("--shape", job.fill.shape, "flat, fair or auto")
      ->check(CLI::IsMember({"flat", "fair", "auto"}))
      ->capture_default_str();
  submit_cmd->add_flag("--binary", job.fill.binary, "Binary PLY/STL result");
  submit_cmd->add_flag("--wait", job.wait,
                       "Wait for the job, showing progress, and print its report");
  submit_cmd->add_option("-o,--output", job.fill.output,
                         "With --wait: write the result here (atomically)");
  submit_cmd->add_flag("--json", job.fill.json, "Print JSON");
  auto* status_cmd = job_cmd->add_subcommand("status", "Print a job's state and progress");
  auto* wait_cmd =
      job_cmd->add_subcommand("wait", "Wait for a job to finish (progress on a terminal)");
  auto* cancel_cmd = job_cmd->add_subcommand("cancel", "Cancel a queued or running job");
  auto* fetch_cmd = job_cmd->add_subcommand("fetch", "Download a finished job's repaired mesh");
  auto* list_cmd = job_cmd->add_subcommand("list", "List your jobs");
  for (auto* c : {status_cmd, wait_cmd, cancel_cmd, fetch_cmd}) {
    c->add_option("JOB_ID", job.job_id, "Job id (from `job submit`)")->required();
    c->add_flag("--json", job.fill.json, "Print JSON");
  }
  list_cmd->add_flag("--json", job.fill.json, "Print JSON");
  wait_cmd->add_option("-o,--output", job.fill.output, "Write the result here when it succeeds");
  fetch_cmd->add_option("-o,--output", job.fill.output, "Where to write the result")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitUsage;
  }
  try {
    if (*info_cmd) return run_info(info, std::cout, std::cerr);
    if (*holes_cmd) {
      return remote.server.empty() ? run_holes(holes, std::cout, std::cerr)
                                   : run_holes_remote(holes, remote, std::cout, std::cerr);
    }
    if (*job_cmd) {
      for (auto* c : job_cmd->get_subcommands()) job.action = c->get_name();
      if (!job_near_text.empty()) {
        touchmend::geometry::Vec3 p;
        if (!parse_point(job_near_text, p)) {
          std::cerr << "error: --near expects three finite numbers X,Y,Z, got '" << job_near_text
                    << "'\n";
          return kExitUsage;
        }
        job.fill.near = p;
      }
      return run_job(job, remote, std::cout, std::cerr);
    }
    if (*fill_cmd) {
      if (!near_text.empty()) {
        touchmend::geometry::Vec3 p;
        if (!parse_point(near_text, p)) {
          std::cerr << "error: --near expects three finite numbers X,Y,Z, got '" << near_text
                    << "'\n";
          return kExitUsage;
        }
        fill.near = p;
      }
      return remote.server.empty() ? run_fill(fill, std::cout, std::cerr)
                                   : run_fill_remote(fill, remote, std::cout, std::cerr);
    }
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitBadInput;
  }
  return kExitUsage;
}
