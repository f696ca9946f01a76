// The gateway's flight routes (docs/web.md, "Flight").
#include <httplib.h>

#include <algorithm>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "nlohmann/json.hpp"
#include "web/flight_session.h"
#include "web/gateway.h"
#include "web/gateway_internal.h"
#include "web/proto_json.h"

namespace riskplan::web {

using namespace gateway_internal;  // NOLINT: the route files' shared helpers
using Json = nlohmann::json;

// Flights (docs/web.md, "Flight"): a Fly session the gateway flies itself.

// POST /api/flights, body: {"open": FlightOpen (its plan a PlanRequest with
// the page's start and goal), "speedup": flight seconds per real second}.
// 201 {id, events}.
void Gateway::PostFlight(const httplib::Request& req, httplib::Response& res) {
  Json body = Json::parse(req.body, nullptr, /*allow_exceptions=*/false);
  if (!body.is_object()) {
    return SendGatewayError(res, absl::InvalidArgumentError(
                                     "the body must be a JSON object with the fields open, "
                                     "speedup"));
  }
  for (auto it = body.begin(); it != body.end(); ++it) {
    if (it.key() != "open" && it.key() != "speedup") {
      return SendGatewayError(
          res, absl::InvalidArgumentError(absl::StrFormat(
                   "unknown field '%s'; the body has the fields open, speedup", it.key())));
    }
  }
  v1::FlightOpen open;
  if (!body.contains("open")) {
    return SendGatewayError(res, absl::InvalidArgumentError(
                                     "'open' is required: the FlightOpen of the session"));
  }
  if (absl::Status s = JsonMessageField(body, "open", &open); !s.ok()) return SendGatewayError(res, s);
  double speedup = 10.0;
  if (body.contains("speedup")) {
    if (!body["speedup"].is_number()) {
      return SendGatewayError(res, absl::InvalidArgumentError("'speedup' must be a number"));
    }
    speedup = body["speedup"].get<double>();
  }
  // What the gateway can know of the mission, as for a plan (a start
  // outside the map, an unknown map, the budget), named as open.plan's.
  if (absl::Status s = CheckPlan(open.plan()); !s.ok()) {
    return SendGatewayError(res, absl::Status(s.code(), absl::StrCat("open.plan: ", s.message())));
  }
  open.mutable_plan()->set_include_tree(false);
  auto session = flights_.Start(std::move(open), speedup, client_.channel());
  if (!session.ok()) return SendGatewayError(res, session.status());
  const std::string& id = (*session)->id();
  SendJson(res, Json{{"id", id}, {"events", absl::StrCat("/api/flights/", id, "/events")}}.dump(),
           201);
}

std::shared_ptr<FlightSession> Gateway::FindFlight(const httplib::Request& req,
                                                   httplib::Response& res) {
  std::shared_ptr<FlightSession> session = flights_.Find(req.matches[1]);
  if (!session) {
    SendError(res, 404, "NOT_FOUND",
              absl::StrCat("no flight '", std::string(req.matches[1]), "' on this gateway"),
              "gateway");
  }
  return session;
}

void Gateway::GetFlight(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<FlightSession> session = FindFlight(req, res);
  if (!session) return;
  SendJson(res, Json{{"id", session->id()},
                     {"state", session->state()},
                     {"last_event_id", session->events().last_event_id()}}
                    .dump());
}

void Gateway::GetFlightEvents(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<FlightSession> session = FindFlight(req, res);
  if (!session) return;
  ServeEvents(std::shared_ptr<EventLog>(session, &session->events()), req, res);
}

// POST /api/flights/ID/inputs, body: a FlightInput with add_zone,
// remove_zone or wind. 200 {"sent": true}; the server's answer (a new
// version, or a refusal) arrives as an event.
void Gateway::PostFlightInput(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<FlightSession> session = FindFlight(req, res);
  if (!session) return;
  v1::FlightInput input;
  if (absl::Status s = FromJson(req.body, &input); !s.ok()) return SendGatewayError(res, s);
  if (absl::Status s = session->Input(input); !s.ok()) return SendGatewayError(res, s);
  SendJson(res, Json{{"sent", true}}.dump());
}

void Gateway::PostFlightEnd(const httplib::Request& req, httplib::Response& res) {
  std::shared_ptr<FlightSession> session = FindFlight(req, res);
  if (!session) return;
  SendJson(res, Json{{"ended", session->End()}}.dump());
}

}  // namespace riskplan::web
