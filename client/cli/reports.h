#pragma once

//! \file reports.h
//! \brief Text and JSON renderings of validation reports, holes and fill results.

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/geometry/hole_filling.h"
#include "server/geometry/holes.h"
#include "server/geometry/mesh_build.h"
#include "server/geometry/mesh_io.h"

namespace touchmend::cli {

nlohmann::json to_json(const geometry::ValidationReport& report);
nlohmann::json to_json(const geometry::Hole& hole);
nlohmann::json to_json(const geometry::HoleFillReport& report);

std::string validation_text(const geometry::ValidationReport& report);
std::string holes_text(const std::vector<geometry::Hole>& holes);
std::string fill_text(const geometry::HoleFillReport& report);

//! "  pinched at vertex 12" (or "vertices 12, 40"), for a hole listing; empty for none.
std::string pinch_note(const std::vector<std::uint32_t>& pinched_at);

//! "  border of a separate piece of 2 faces" for a fragment's outline; empty for 0.
std::string fragment_note(std::size_t fragment_faces);
//! The fill's closing line: "filled F of S selected holes (O left open, K skipped[, R closed by
//! removing a fragment]; H holes in the mesh)", the same locally and through a server.
std::string fill_summary(std::size_t filled, std::size_t selected, std::size_t open,
                         std::size_t skipped, std::size_t fragments_removed, std::size_t found);

}  // namespace touchmend::cli
