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
  app.add_option("--retries", remote.retries,
                 "With --server: connect and send a call again up to this many times while the\n"
                 "server is unreachable or restarting, waiting 0.2 s, 0.4 s, ... up to 5 s between\n"
                 "tries (about 20 s in all by default). Edits carry request ids, so one sent again\n"
                 "is never made twice")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));

  InfoArgs info;
  auto* info_cmd =
      app.add_subcommand("info",
                         "Counts, bounds and a validation report (non-manifold edges and\n"
                         "vertices, degenerate, duplicate, flipped and refused faces)");
  info_cmd->add_option("FILE", info.file, "Mesh file")->required();
  info_cmd->add_flag("--json", info.json, "Print JSON instead of text");

  HolesArgs holes;
  auto* holes_cmd = app.add_subcommand(
      "holes",
      "List the holes: stable id (smallest boundary vertex index),\n"
      "boundary edges, perimeter, area, centroid, normal, simple/complex;\n"
      "a loop through a vertex twice is marked 'pinched at vertex N' (fill\n"
      "closes the pinch with one triangle first), the outline of a small\n"
      "separate piece says 'border of a separate piece of N faces' (debris:\n"
      "fill --remove-fragments deletes it), a hole that cannot be filled at all\n"
      "says why ('unfillable: ...')");
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
          "flat: keep the refined triangulation (on curved surroundings its triangles are\n"
          "mended across the triangulation's folds); fair: bi-Laplacian fairing that continues\n"
          "the surrounding surface (exactly, where it is a sphere or a quadric); auto: flat\n"
          "where the surroundings are planar or piecewise planar along creases (CAD), else\n"
          "fair (the report says why). A faired patch that is refused (a balloon, a\n"
          "crossing) is filled flat instead, or with a membrane where the flat one would keep a\n"
          "triangle under 15 degrees")
      ->check(CLI::IsMember({"flat", "fair", "auto"}))
      ->capture_default_str();
  fill_cmd
      ->add_option(
          "--sharp", fill.sharp,
          "auto (default): find the creases (sharp edges) that cross each hole, pair them\n"
          "into Hermite curves or extend three or more to a common corner, and fill the\n"
          "hole split along those curves, so the creases run through the patch (holes no\n"
          "crease crosses get the plain fill); off: plain fill everywhere")
      ->check(CLI::IsMember({"off", "auto"}))
      ->capture_default_str();
  fill_cmd
      ->add_option(
          "--crease-angle", fill.crease_angle,
          "With --sharp auto: an edge whose faces meet at more than this many degrees is a\n"
          "crease (a weaker one, down to 30, may continue a crease across a hole)")
      ->check(CLI::Range(1.0, 179.0))
      ->capture_default_str();
  fill_cmd->add_flag(
      "--remove-fragments", fill.remove_fragments,
      "A selected loop that is the whole border of a small separate piece (`holes` marks it\n"
      "\"border of a separate piece of N faces\": a lone triangle, scan debris) cannot be\n"
      "filled; with this flag the piece is deleted instead (its vertices too, unless the\n"
      "surface shares them) and the report says so");
  fill_cmd->add_flag("--json", fill.json, "Print the fill report as JSON");
  fill_cmd->add_flag("--binary", fill.binary, "Write binary PLY (doubles) or binary STL (floats)");
  fill_cmd->add_flag("--strict", fill.strict, "Exit with 3 when a selected hole is left open");

  SharpenArgs sharpen;
  auto* sharpen_cmd = app.add_subcommand(
      "sharpen",
      "Fill a hole and restore the sharp edge through it from four points picked along the\n"
      "crease (seed 000 §4.2): P1, P2 on one side of the hole (P2 nearest it), P3, P4 on the\n"
      "other (P3 nearest). The Hermite curve runs P2 -> P3 leaving along P1->P2 and arriving\n"
      "along P3->P4; the points are snapped onto the surface first. Beyond the thesis: several\n"
      "curves, and creases meeting at a corner inside the hole (--corner)");
  sharpen_cmd->add_option("FILE", sharpen.file, "Mesh file with the hole")->required();
  sharpen_cmd->add_option("-o,--output", sharpen.output, "Where to write the result")->required();
  sharpen_cmd->add_option("--hole", sharpen.hole, "Hole id (see `touchmend holes`)")->required();
  sharpen_cmd
      ->add_option("--points", sharpen.points,
                   "P1;P2;P3;P4 as X,Y,Z;X,Y,Z;X,Y,Z;X,Y,Z (quote it in the shell);\n"
                   "repeat --points for more curves through the hole (split only)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sharpen_cmd->add_option(
      "--corner", sharpen.corner,
      "Creases meeting at a corner inside the hole (three or more; split only), two\n"
      "points each: a point on the crease away from the hole, then where it meets the\n"
      "rim (X,Y,Z;X,Y,Z;...). They are extended along their tangents to the point\n"
      "nearest all of them. With --points too, those curves are kept as well");
  sharpen_cmd
      ->add_option("--k1", sharpen.k1,
                   "Start tangent length (model units; default: the circular-arc length\n"
                   "for the turn between the two directions, = |P3-P2| when straight)")
      ->check(CLI::PositiveNumber);
  sharpen_cmd->add_option("--k4", sharpen.k4, "End tangent length (default as --k1)")
      ->check(CLI::PositiveNumber);
  sharpen_cmd
      ->add_option("--method", sharpen.method,
                   "split: fill the hole on both sides of the sampled curve (the crease by\n"
                   "construction; closer to ground truth on the shared cases); push-down: the\n"
                   "thesis' tool - snap the patch onto the guiding surface, push its vertices to\n"
                   "the curve (Algorithms V, VI), then shape the rest (--finish)")
      ->check(CLI::IsMember({"split", "push-down"}))
      ->capture_default_str();
  sharpen_cmd
      ->add_option("--finish", sharpen.finish,
                   "push-down only, how the rest of the patch is shaped after the push: fair\n"
                   "(default: each side of the curve faired with the curve held), smooth (the\n"
                   "thesis' normal propagation, Algorithm VII) or none. A finish that would make\n"
                   "the patch intersect the mesh is undone and reported")
      ->check(CLI::IsMember({"fair", "smooth", "none"}));
  sharpen_cmd
      ->add_option("--tangents", sharpen.tangents,
                   "Where the curve's end directions come from: crease (default: where P1 (P4)\n"
                   "lies on a crease that reaches the rim at P2's (P3's) boundary vertex, that\n"
                   "crease's fitted tangent, so an unsteady pick does not bend the curve; the\n"
                   "chord elsewhere) or chord (the thesis: unit(P2-P1), unit(P4-P3))")
      ->check(CLI::IsMember({"crease", "chord"}))
      ->capture_default_str();
  sharpen_cmd
      ->add_option("--depth", sharpen.depth,
                   "push-down only: push this far past the curve (free-form edges)")
      ->check(CLI::NonNegativeNumber);
  sharpen_cmd->add_option("--shape", sharpen.shape, "Shape of the first fill: flat, fair or auto")
      ->check(CLI::IsMember({"flat", "fair", "auto"}))
      ->capture_default_str();
  sharpen_cmd
      ->add_option("--refine-iterations", sharpen.refine_iterations, "Rounds of Liepa refinement")
      ->check(CLI::Range(1, 5))
      ->capture_default_str();
  sharpen_cmd->add_flag("--json", sharpen.json, "Print JSON");
  sharpen_cmd->add_flag("--binary", sharpen.binary, "Binary PLY/STL output");

  GapsArgs gaps;
  auto* gaps_cmd = app.add_subcommand(
      "gaps",
      "List gaps: runs of boundary vertices facing another boundary (or a distant part of the\n"
      "same one) across empty space, e.g. between two registered scans or a cut-out strip");
  gaps_cmd->add_option("FILE", gaps.file, "Mesh file")->required();
  gaps_cmd
      ->add_option("--max-width", gaps.max_width,
                   "Widest gap (model units; default 3x the mean boundary edge length)")
      ->check(CLI::NonNegativeNumber);
  gaps_cmd->add_flag("--json", gaps.json, "Print JSON (with the vertex runs)");

  BridgeArgs bridge;
  auto* bridge_cmd = app.add_subcommand(
      "bridge",
      "Bridge gaps with a zipper triangulation (each triangle checked like a manual stitch:\n"
      "never flipped, non-manifold or intersecting) and close the small holes left at the ends");
  bridge_cmd->add_option("FILE", bridge.file, "Mesh file")->required();
  bridge_cmd->add_option("-o,--output", bridge.output, "Where to write the result")->required();
  auto* bridge_all = bridge_cmd->add_flag("--all", bridge.all, "Bridge every gap found");
  auto* bridge_ids =
      bridge_cmd->add_option("--gap", bridge.gap_ids, "Gap ids (see `touchmend gaps`)");
  bridge_all->excludes(bridge_ids);
  bridge_cmd->add_option("--max-width", bridge.max_width, "As for `gaps`")
      ->check(CLI::NonNegativeNumber);
  bridge_cmd->add_flag("--json", bridge.json, "Print JSON");
  bridge_cmd->add_flag("--binary", bridge.binary, "Binary PLY/STL output");

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
  submit_cmd->add_flag("--remove-fragments", job.fill.remove_fragments,
                       "Delete the small separate pieces a selected loop borders (see `fill`)");
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
    if (*sharpen_cmd) {
      return remote.server.empty() ? run_sharpen(sharpen, std::cout, std::cerr)
                                   : run_sharpen_remote(sharpen, remote, std::cout, std::cerr);
    }
    if (*gaps_cmd) {
      return remote.server.empty() ? run_gaps(gaps, std::cout, std::cerr)
                                   : run_gaps_remote(gaps, remote, std::cout, std::cerr);
    }
    if (*bridge_cmd) {
      return remote.server.empty() ? run_bridge(bridge, std::cout, std::cerr)
                                   : run_bridge_remote(bridge, remote, std::cout, std::cerr);
    }
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
