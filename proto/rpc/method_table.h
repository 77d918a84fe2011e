#pragma once

//! \file method_table.h
//! \brief The RPC methods of touchmend.v1.Repair with their streaming kinds, read from the
//! generated descriptors (so the table cannot drift from repair.proto).

#include <string>
#include <string_view>
#include <vector>

namespace touchmend::rpc {

struct MethodInfo {
  std::string full_name;    //!< "/touchmend.v1.Repair/FillHoles", as sent in CALL frames
  std::string name;         //!< "FillHoles"
  std::string input_type;   //!< "touchmend.v1.FillHolesRequest"
  std::string output_type;  //!< "touchmend.v1.EditResponse"
  bool client_streaming = false;
  bool server_streaming = false;
};

//! Every method of the Repair service, in declaration order.
const std::vector<MethodInfo>& repair_methods();
//! The method with this full name, or nullptr.
const MethodInfo* find_method(std::string_view full_name);
//! "/touchmend.v1.Repair/" + short name.
std::string method_path(std::string_view short_name);

}  // namespace touchmend::rpc
