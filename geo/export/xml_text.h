// XmlEscape: text for an XML document (KML here, the client's SVG pictures),
// with the five characters XML gives a meaning written as entities, so that a
// map name, a description or a mission id (the client's free text) can sit in
// element text or in a quoted attribute value without breaking the document.
#ifndef RISKPLAN_GEO_EXPORT_XML_TEXT_H_
#define RISKPLAN_GEO_EXPORT_XML_TEXT_H_

#include <string>

#include "absl/strings/string_view.h"

namespace riskplan::geo {

// `text` with '&', '<', '>', '"' and '\'' escaped; every other byte as it is.
std::string XmlEscape(absl::string_view text);

}  // namespace riskplan::geo

#endif  // RISKPLAN_GEO_EXPORT_XML_TEXT_H_
