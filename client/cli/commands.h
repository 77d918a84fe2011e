#pragma once

//! \file commands.h
//! \brief The `touchmend` subcommands, separated from argument parsing so tests can call them.

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "server/geometry/hermite_curve.h"
#include "server/geometry/mesh.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"
#include "server/geometry/sharpen.h"
#include "touchmend/v1/repair.pb.h"

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
  //! How many times a call is sent again when the server is unreachable or restarting
  //! (UNAVAILABLE), with backoff; 0: never (net::RetryPolicy).
  int retries = 6;
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
  std::string sharp = "auto";     //!< auto | off: retain the creases that cross each hole
  double crease_angle = 50;       //!< dihedral angle (degrees) above which an edge is a crease
  bool remove_fragments = false;  //!< delete the small separate pieces a selected loop borders
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

struct SharpenArgs {
  std::string file;
  std::string output;
  std::uint32_t hole = 0;
  std::vector<std::string> points;  //!< one "X,Y,Z;X,Y,Z;X,Y,Z;X,Y,Z" per curve
  std::string corner;               //!< "X,Y,Z;X,Y,Z;..." far and rim point per corner crease
  double k1 = 0, k4 = 0;
  double depth = 0;
  std::string method = "split";
  std::string finish;               //!< push-down only: fair, smooth or none (empty: fair)
  std::string tangents = "crease";  //!< crease or chord
  std::string shape = "auto";
  int refine_iterations = 3;
  bool json = false;
  bool binary = false;
};

struct GapsArgs {
  std::string file;
  double max_width = 0;
  bool json = false;
};

struct BridgeArgs {
  std::string file;
  std::string output;
  std::vector<std::uint32_t> gap_ids;
  bool all = false;
  double max_width = 0;
  bool json = false;
  bool binary = false;
};

int run_sharpen(const SharpenArgs& args, std::ostream& out, std::ostream& err);
int run_sharpen_remote(const SharpenArgs& args, const RemoteArgs& remote, std::ostream& out,
                       std::ostream& err);
int run_gaps_remote(const GapsArgs& args, const RemoteArgs& remote, std::ostream& out,
                    std::ostream& err);
int run_bridge_remote(const BridgeArgs& args, const RemoteArgs& remote, std::ostream& out,
                      std::ostream& err);
int run_gaps(const GapsArgs& args, std::ostream& out, std::ostream& err);
int run_bridge(const BridgeArgs& args, std::ostream& out, std::ostream& err);

//! A mesh file read and built into a mesh.
struct Loaded {
  geometry::BuildResult built;
  geometry::ReadReport read;
};

//! Reads and builds a mesh; on failure prints the problem and returns nullopt.
std::optional<Loaded> load(const std::string& file, std::ostream& err);

//! Parses "X,Y,Z;X,Y,Z;X,Y,Z;X,Y,Z" into four finite points.
bool parse_points(const std::string& text, geometry::HermitePoints& points);

//! The picks of `sharpen` (--points, once per curve, and --corner), checked against the method:
//! more than one curve or a corner only with the split variant. On failure prints why.
bool parse_sharpen_picks(const SharpenArgs& args, geometry::PickedCreases& picked,
                         std::ostream& err);

//! Parses "X,Y,Z" into a finite point.
bool parse_point(const std::string& text, geometry::Vec3& point);

//! The wire's format for a mesh file, by its extension (geometry::format_from_path); false if
//! it is none the reader knows.
bool wire_format(const std::string& path, v1::MeshFormat& format);

}  // namespace touchmend::cli
