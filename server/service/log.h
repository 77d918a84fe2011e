#pragma once

//! \file log.h
//! \brief Structured logs: one JSON object per line on stderr through spdlog (SERVICE.md
//! §6.1: `ts`, `level`, `event` plus context fields; never tokens or mesh payloads).

#include <string_view>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

namespace touchmend::service {

//! Sets up the process-wide logger (JSON lines on stderr) at \p level ("info", "debug"...).
void init_logging(const std::string& level);

void log_event(spdlog::level::level_enum level, std::string_view event, nlohmann::json fields = {});

}  // namespace touchmend::service
