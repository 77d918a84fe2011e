#pragma once

//! \file mesh_io.h
//! \brief Reading and writing STL (ASCII, binary), OBJ, OFF and PLY (ASCII, binary).
//!
//! \details touchmend parses and writes these formats itself instead of going through
//! OpenMesh 9.0's readers and writers: both convert every coordinate through `float`
//! (0.12345678901234567 is read and written as 0.12345679104328156 whatever precision is
//! passed), which breaks the rule that existing vertices keep their exact coordinates.
//! Here ASCII numbers are parsed with `std::from_chars` into doubles and written with the
//! shortest representation that round-trips (`std::to_chars`); binary PLY is written with
//! `double` properties. Binary STL can only hold `float`: writing it reports a warning
//! when a coordinate changes.
//!
//! Readers never crash on bad input: they return an error naming the problem (and the
//! line or byte offset where it was found).

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "server/geometry/mesh.h"

namespace touchmend::geometry {

enum class MeshFormat { Off, Obj, Ply, Stl };

//! The format for a path's extension (case-insensitive); false if it is not one we know.
bool format_from_path(const std::string& path, MeshFormat& format);
const char* format_name(MeshFormat format);

struct ReadOptions {
  bool weld_stl_vertices = true;  //!< merge STL corners with identical coordinates
  std::size_t max_file_bytes = std::size_t{4} << 30;  //!< refuse larger files (clear error)
  std::size_t max_elements = 100'000'000;  //!< refuse declared vertex/face counts above this
};

struct ReadReport {
  MeshFormat format = MeshFormat::Off;
  bool binary = false;
  std::size_t polygons_triangulated = 0;  //!< faces with more than 3 corners, fan-split
  std::size_t stl_corners_welded = 0;     //!< STL corners merged into an existing vertex
};

struct ReadResult {
  bool ok = false;
  std::string error;  //!< set when !ok: what is wrong and where
  MeshSoup soup;
  ReadReport report;
};

//! Reads a mesh file; the format comes from the extension.
ReadResult read_mesh_file(const std::string& path, const ReadOptions& options = {});

//! Parses mesh file contents already in memory (used by the file reader, tests, fuzzers).
ReadResult parse_mesh(std::string_view bytes, MeshFormat format, const ReadOptions& options = {});

struct WriteOptions {
  bool binary = false;  //!< binary PLY (double) or binary STL (float); ignored for OFF/OBJ
};

struct WriteResult {
  bool ok = false;
  std::string error;
  std::vector<std::string> warnings;
  std::size_t vertices_written = 0;
  std::size_t faces_written = 0;
};

//! Serialises the non-deleted vertices and faces of \p mesh (vertex order kept, deleted
//! elements skipped) into \p out.
WriteResult serialize_mesh(const Mesh& mesh, MeshFormat format, const WriteOptions& options,
                           std::string& out);

//! Writes \p mesh to \p path atomically: the bytes go to a temporary file in the same
//! directory, are flushed to disk, and the file is renamed over \p path. A failure leaves
//! any existing file at \p path untouched.
WriteResult write_mesh_file(const Mesh& mesh, const std::string& path,
                            const WriteOptions& options = {});

//! Writes \p bytes to \p path atomically (temporary file in the same directory, fsync,
//! rename, fsync of the directory). On failure \p error names the problem and any existing
//! file at \p path is untouched.
bool write_file_atomically(const std::string& path, std::string_view bytes, std::string& error);

}  // namespace touchmend::geometry
