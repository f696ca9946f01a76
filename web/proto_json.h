// The API messages in Protobuf's canonical JSON form, as the page sends and
// reads them: field names as in the .proto (snake_case), every field printed
// (defaults too), enums by name, 64-bit integers as strings, NaN as "NaN".
#ifndef RISKPLAN_WEB_PROTO_JSON_H_
#define RISKPLAN_WEB_PROTO_JSON_H_

#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "google/protobuf/message.h"

namespace riskplan::web {

// One line of JSON. A message Protobuf cannot print (it can always print
// the API's) gives "{}".
std::string ToJson(const google::protobuf::Message& message);

// Parses `json` into `*message`. Unknown fields are refused, so that a
// misspelt field is an error rather than a default. InvalidArgument with
// Protobuf's own description of what is wrong.
absl::Status FromJson(absl::string_view json, google::protobuf::Message* message);

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_PROTO_JSON_H_
