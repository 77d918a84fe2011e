#include "proto/rpc/method_table.h"

#include <google/protobuf/descriptor.h>

#include "touchmend/v1/repair.pb.h"

namespace touchmend::rpc {

namespace {
constexpr std::string_view kServiceName = "touchmend.v1.Repair";
}

const std::vector<MethodInfo>& repair_methods() {
  static const std::vector<MethodInfo> methods = [] {
    std::vector<MethodInfo> list;
    // Any generated message's file descriptor carries the service.
    const auto* file = v1::SessionRef::descriptor()->file();
    const auto* service = file->pool()->FindServiceByName(std::string(kServiceName));
    if (service == nullptr) return list;
    for (int i = 0; i < service->method_count(); ++i) {
      const auto* m = service->method(i);
      list.push_back({method_path(m->name()), m->name(), m->input_type()->full_name(),
                      m->output_type()->full_name(), m->client_streaming(), m->server_streaming()});
    }
    return list;
  }();
  return methods;
}

const MethodInfo* find_method(std::string_view full_name) {
  for (const auto& m : repair_methods()) {
    if (m.full_name == full_name) return &m;
  }
  return nullptr;
}

std::string method_path(std::string_view short_name) {
  std::string path = "/";
  path += kServiceName;
  path += "/";
  path += short_name;
  return path;
}

}  // namespace touchmend::rpc
