#pragma once

//! \file commands.h
//! \brief The `touchmend` subcommands, separated from argument parsing so tests can call them.

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::cli {

enum ExitCode : int {
  kExitOk = 0,
  kExitBadInput = 1,  //!< the input file (or a hole id) is wrong; the message names the problem
  kExitUsage = 2,     //!< the command line is wrong
  kExitLeftOpen = 3,  //!< --strict: some selected holes could not be filled
  kExitServer = 4,    //!< the server could not be reached, refused the token, or failed
};

//! Where a command runs when --server is given.
struct RemoteArgs {
  std::string server;  //!< HOST:PORT; empty = in-process
  std::string token;   //!< bearer token (or $TOUCHMEND_TOKEN)
  std::string tls_ca;  //!< CA file: connect with TLS and verify the server against it
  bool tls = false;    //!< TLS with the system's CAs
};

struct InfoArgs {
  std::string file;
  bool json = false;
};

struct HolesArgs {
  std::string file;
  bool json = false;
};

struct FillArgs {
  std::string file;
  std::string output;
  bool all = false;
  std::vector<std::uint32_t> hole_ids;
  std::optional<geometry::Vec3> near;
  std::size_t max_boundary = 0;
  int refine_iterations = 3;
  std::string shape = "auto";
  bool json = false;
  bool binary = false;
  bool strict = false;
};

struct JobArgs {
  std::string action;  //!< submit, status, wait, cancel, fetch, list
  std::string job_id;
  FillArgs fill;  //!< submit: input file, selection and options (output: --wait -o)
  bool wait = false;
};

int run_info(const InfoArgs& args, std::ostream& out, std::ostream& err);
int run_holes_remote(const HolesArgs& args, const RemoteArgs& remote, std::ostream& out,
                     std::ostream& err);
int run_fill_remote(const FillArgs& args, const RemoteArgs& remote, std::ostream& out,
                    std::ostream& err);
int run_job(const JobArgs& args, const RemoteArgs& remote, std::ostream& out, std::ostream& err);
int run_holes(const HolesArgs& args, std::ostream& out, std::ostream& err);
int run_fill(const FillArgs& args, std::ostream& out, std::ostream& err);

//! Parses "X,Y,Z" into a finite point.
bool parse_point(const std::string& text, geometry::Vec3& point);

}  // namespace touchmend::cli
