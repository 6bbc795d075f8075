// The schema stored with each recorded channel: the OMG IDL text of the type, as the build's idl/*.idl
// files define it (embedded at build time), so a recording documents its own bytes.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace ddsnav::record {

// IDL text defining `type_name` (e.g. "ddsnav::msg::Path"): the file that declares the struct, preceded by
// the files it includes (#include lines removed, so the text stands alone). nullopt for a type no idl/
// file of this build declares.
std::optional<std::string> idlSchemaFor(std::string_view type_name);

}  // namespace ddsnav::record
