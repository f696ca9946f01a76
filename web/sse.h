// Server-Sent Events framing (the WHATWG HTML standard's "text/event-stream"),
// for the gateway's event streams. Pure functions, no I/O.
#ifndef RISKPLAN_WEB_SSE_H_
#define RISKPLAN_WEB_SSE_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/strings/string_view.h"

namespace riskplan::web {

// One event as it goes on the wire:
//   id: ID\n event: TYPE\n data: LINE\n (one data line per line of `data`) \n
// A browser's EventSource remembers ID and sends it back as Last-Event-ID
// when it reconnects. `data` may hold any text: it is split on "\n", "\r\n"
// and "\r" (each line becomes one "data:" field, which the browser joins with
// "\n" again); an empty `data` is one empty data line. `type` must be a
// non-empty word without line breaks (REQUIRES).
std::string FormatSseEvent(uint64_t id, absl::string_view type, absl::string_view data);

// A comment line, ignored by browsers: what keeps an idle stream alive and
// finds out that its reader has gone (the write fails).
std::string FormatSseComment(absl::string_view text);

// The stream's first bytes: how long a browser waits before reconnecting.
std::string FormatSseRetry(int retry_ms);

// The id a reconnecting reader has seen, from its Last-Event-ID header (or
// the page's own last_event_id query parameter): a decimal number of at most
// 19 digits, surrounding spaces allowed. nullopt for anything else; an empty
// value means "nothing seen", 0.
std::optional<uint64_t> ParseLastEventId(absl::string_view value);

}  // namespace riskplan::web

#endif  // RISKPLAN_WEB_SSE_H_
