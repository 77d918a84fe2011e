#include "server/service/log.h"

#include <spdlog/sinks/stdout_sinks.h>

namespace touchmend::service {

void init_logging(const std::string& level) {
  auto logger = spdlog::stderr_logger_mt("touchmend");
  // The timestamp and level are spdlog's; the rest of the object is the message.
  logger->set_pattern(R"({"ts":"%Y-%m-%dT%H:%M:%S.%fZ","level":"%l",%v})",
                      spdlog::pattern_time_type::utc);
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

void log_event(spdlog::level::level_enum level, std::string_view event, nlohmann::json fields) {
  if (!spdlog::default_logger_raw()->should_log(level)) return;
  if (!fields.is_object()) fields = nlohmann::json::object();
  std::string body = "\"event\":" + nlohmann::json(event).dump();
  for (const auto& [key, value] : fields.items()) {
    body += ",";
    body += nlohmann::json(key).dump();
    body += ":";
    body += value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }
  spdlog::default_logger_raw()->log(level, "{}", body);
}

}  // namespace touchmend::service
