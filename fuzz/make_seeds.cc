// Writes the seed corpora of the binary-input fuzz targets (map_bundle,
// shim_session, shim_client, request) into DIR/<target>/, from the project's
// own writers and encoders, so that each seed is a valid input in the
// target's format (fuzz/corpus/ holds the result; the text targets' seeds
// are written by hand). Usage: make_seeds DIR
#include <sys/socket.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "accel/blobs.h"
#include "accel/frame_io.h"
#include "accel/known_answer.h"
#include "accel/shim/device.h"
#include "accel/shim/shim_session.h"
#include "accel/shim_client.h"
#include "core/map/demo_city.h"
#include "core/map/map_bundle.h"
#include "core/map/risk_map.h"
#include "fuzz/fuzz_support.h"
#include "fuzz/shim_records.h"
#include "geo/geo_frame.h"
#include "net/net.h"
#include "nlohmann/json.hpp"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::fuzz {
namespace {

namespace fs = std::filesystem;
using namespace riskplan::accel;

void Write(const fs::path& dir, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary) << bytes;
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// ---- map_bundle ----

std::shared_ptr<const RiskMap> SmallMap(bool geo) {
  MapHeader header;
  header.name = "tiny-town";
  header.x0 = 100.0;
  header.y0 = -50.0;
  header.res = 10.0;
  header.nx = 6;
  header.ny = 5;
  header.provenance = "fuzz seed";
  if (geo) header.geo = GeoReference{47.4, 8.5, "local ENU tangent plane"};
  MapLayers layers;
  const int cells = header.nx * header.ny;
  for (int c = 0; c < cells; ++c) {
    layers.density.push_back(0.001f * static_cast<float>(c % 7));
    layers.shelter.push_back(static_cast<float>(c % 11));
    layers.terrain.push_back(100.0f + static_cast<float>(c % 5));
    layers.nofly.push_back(c == 14 ? 1 : 0);
  }
  layers.landing_sites = {{"field-1", 1, 1}, {"", 4, 3}};
  absl::StatusOr<std::shared_ptr<const RiskMap>> map =
      RiskMap::Create(std::move(header), std::move(layers), 10.0, 10.0);
  if (!map.ok()) Fail(map.status().ToString());
  return *map;
}

// The bundle of `map` in map_bundle_fuzz's format; `edit` may change the
// manifest first.
std::string BundleSeed(const RiskMap& map, void (*edit)(nlohmann::json&)) {
  const ScratchDir scratch;
  if (!WriteMapBundle(map, scratch.path().string()).ok()) Fail("WriteMapBundle");
  nlohmann::ordered_json manifest =
      nlohmann::ordered_json::parse(ReadFile(scratch.path() / "manifest.json"));
  nlohmann::json plain = manifest;
  if (edit != nullptr) edit(plain);
  std::string seed = edit != nullptr ? plain.dump(1) : manifest.dump(2);
  for (const char* file : {"density.f32", "shelter.f32", "terrain.f32", "nofly.u8"}) {
    seed += std::string("\n%%file ") + file + "\n" + ReadFile(scratch.path() / file);
  }
  return seed;
}

void MapBundleSeeds(const fs::path& out) {
  const fs::path dir = out / "map_bundle";
  Write(dir, "valid-with-checksums", BundleSeed(*SmallMap(false), nullptr));
  Write(dir, "valid-geo-no-checksums", BundleSeed(*SmallMap(true), [](nlohmann::json& m) {
          for (auto& [name, layer] : m["layers"].items()) layer.erase("sha256");
        }));
  Write(dir, "no-landing-sites", BundleSeed(*SmallMap(false), [](nlohmann::json& m) {
          m.erase("landing_sites");
          for (auto& [name, layer] : m["layers"].items()) layer.erase("sha256");
        }));
}

// ---- shim_session ----

// A 6 x 5 map blob and a kernels blob of 2 height bins x 2 headings.
std::string SmallMapBlob() {
  std::vector<float> density(30), shelter(30);
  for (int c = 0; c < 30; ++c) {
    density[c] = 0.002f * static_cast<float>(c % 5);
    shelter[c] = static_cast<float>(c % 10);
  }
  return EncodeMapBlob(6, 5, density.data(), shelter.data());
}

std::string SmallKernelsBlob() {
  KernelSet set;
  set.height_bins = 2;
  set.heading_bins = 2;
  set.half_width = {0, 1};
  set.weights = {
      {1.0}, {0.5}, {0.1, 0.1, 0.1, 0.1, 0.2, 0.1, 0.1, 0.1, 0.1}, std::vector<double>(9, 0.1)};
  return EncodeKernelsBlob(set);
}

Record Request(MessageType type, std::string payload, uint8_t flags = 0) {
  Record r;
  r.flags = flags;
  r.type = type;
  r.payload = std::move(payload);
  return r;
}

std::string Records(const std::vector<Record>& records) {
  std::string out;
  for (const Record& r : records) AppendRecord(&out, r);
  return out;
}

void ShimSessionSeeds(const fs::path& out) {
  const fs::path dir = out / "shim_session";
  const std::string map = SmallMapBlob();
  const std::string kernels = SmallKernelsBlob();
  const BlobHash map_hash = Sha256(map);
  const BlobHash kernels_hash = Sha256(kernels);
  const Record hello = Request(MessageType::kHello, EncodeHello({"riskplan seed"}));
  const Record ping = Request(MessageType::kPing, EncodePing({0x1234}));
  Write(dir, "hello-ping", Records({hello, ping}));

  std::vector<Record> upload = {hello};
  upload.push_back(Request(MessageType::kPutBlob,
                           EncodePutBlob({BlobKind::kMap, map_hash, map.size(), 0, map}),
                           kFixBlobs));
  const size_t half = kernels.size() / 2;
  upload.push_back(
      Request(MessageType::kPutBlob, EncodePutBlob({BlobKind::kKernels, kernels_hash,
                                                    kernels.size(), 0, kernels.substr(0, half)})));
  upload.push_back(
      Request(MessageType::kPutBlob, EncodePutBlob({BlobKind::kKernels, kernels_hash,
                                                    kernels.size(), half, kernels.substr(half)})));
  EvalRequest eval{map_hash,
                   kernels_hash,
                   {{1, 0, 2, 2}, {2, 1, 0, 0}, {2, 0, 5, 4}, {1, 1, -1, 3}, {2, 1, 9, 9}}};
  upload.push_back(Request(MessageType::kEval, EncodeEval(eval)));
  upload.push_back(ping);
  Write(dir, "upload-and-eval", Records(upload));

  // A kernels blob sent whole with kFixBlobs, then an EVAL naming the fixed
  // blobs, then an EVAL of an unknown blob.
  std::vector<Record> fixed = {
      Request(MessageType::kPutBlob,
              EncodePutBlob({BlobKind::kMap, BlobHash{}, map.size(), 0, map}), kFixBlobs),
      Request(MessageType::kPutBlob,
              EncodePutBlob({BlobKind::kKernels, BlobHash{}, kernels.size(), 0, kernels}),
              kFixBlobs),
      Request(MessageType::kEval, EncodeEval(EvalRequest{{}, {}, {{1, 0, 1, 1}}}), kFixBlobs),
      Request(MessageType::kEval, EncodeEval(EvalRequest{{}, {}, {{1, 0, 1, 1}}}))};
  Write(dir, "fixed-blobs", Records(fixed));

  Record old_version = hello;
  old_version.flags = kVersion;
  old_version.version = 2;
  Write(dir, "other-version", Records({old_version}));
  Record corrupt = ping;
  corrupt.flags = kBadCrc;
  Write(dir, "bad-crc", Records({hello, corrupt}));
  Record raw =
      Request(MessageType::kPing, EncodeFrame(MessageType::kPing, 1, EncodePing({7})), kRaw);
  Write(dir, "raw-ping", Records({raw}));
  Write(dir, "error-as-request",
        Records({Request(MessageType::kError, EncodeError({ShimErrorCode::kInternal, "x", {}}))}));
}

// ---- shim_client ----

// Runs the client's operations against a real shim session on a socketpair
// and returns the shim's replies as records: a seed whose every reply is the
// right one.
std::string RecordExchange(const std::string& ops, uint16_t blob_size) {
  auto [client_end, shim_end] = SocketPair();
  std::vector<Record> replies;
  std::thread shim([&replies, shim = std::move(shim_end)] {
    ModelDevice device(NumberFormat::Board());
    BlobStore store(device.info().format, 63, 1u << 20);
    ShimContext context;
    context.device = &device;
    context.store = &store;
    ShimSession session(&context);
    std::string payload;
    FrameHeader header;
    while (ReadFrame(shim, 1u << 20, absl::Now() + absl::Seconds(5), &header, &payload).ok()) {
      bool close = false;
      const std::string reply = session.Handle(header, payload, &close);
      absl::string_view rest = reply;
      FrameHeader reply_header;
      const absl::string_view reply_payload = TakeFrame(&rest, &reply_header);
      replies.push_back(Request(reply_header.type, std::string(reply_payload)));
      if (!net::SendAll(shim, reply, absl::Now() + absl::Seconds(5)).ok() || close) break;
    }
  });
  // The same operations as shim_client_fuzz.cc, on the same test blob.
  std::string blob(blob_size, '\0');
  uint32_t x = 2463534242u;
  for (char& c : blob) {
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    c = static_cast<char>(x);
  }
  ShimClientOptions options;
  options.upload_chunk_bytes = 1024;
  options.client_name = "fuzz";
  absl::StatusOr<std::unique_ptr<ShimClient>> client =
      ShimClient::Handshake("seed", std::move(client_end), options);
  if (!client.ok()) Fail(client.status().ToString());
  for (const char op : ops) {
    switch (op & 3) {
      case 0:
        (*client)->Ping().IgnoreError();
        break;
      case 1:
        (*client)
            ->PutBlob((op & 4) ? BlobKind::kKernels : BlobKind::kMap, Sha256(blob), blob)
            .IgnoreError();
        break;
      case 2:
        break;  // EVAL of the test blob: no shim holds it, an ERROR is seed enough
      default:
        if (absl::Status s = RunKnownAnswer(**client); !s.ok()) Fail(s.ToString());
        break;
    }
  }
  client->reset();  // closes the connection: the shim's loop ends
  shim.join();
  std::string seed;
  seed.push_back(static_cast<char>(ops.size()));
  seed += ops;
  seed.push_back(static_cast<char>(blob_size & 0xff));
  seed.push_back(static_cast<char>(blob_size >> 8));
  return seed + Records(replies);
}

void ShimClientSeeds(const fs::path& out) {
  const fs::path dir = out / "shim_client";
  Write(dir, "hello-ping", RecordExchange(std::string(1, 0), 0));
  Write(dir, "upload-map-ping", RecordExchange(std::string{1, 0}, 3000));
  Write(dir, "known-answer", RecordExchange(std::string{3, 0}, 0));
  Write(dir, "kernels-upload-refused", RecordExchange(std::string{5, 2}, 100));
}

// ---- request ----

v1::Pose PoseAt(const RiskMap& map, double x, double y, double theta) {
  int i = 0, j = 0;
  map.CellOf(x, y, &i, &j);
  v1::Pose pose;
  pose.set_x(x);
  pose.set_y(y);
  // Above the safe altitude and well under terrain + max_agl (150 m).
  pose.set_z(std::max(map.SafeAltitude(i, j, 30.0), map.terrain(i, j) + 30.0) + 20.0);
  pose.set_theta(theta);
  return pose;
}

std::string Method(char method, const google::protobuf::Message& m) {
  return std::string(1, method) + m.SerializeAsString();
}

void RequestSeeds(const fs::path& out) {
  const fs::path dir = out / "request";
  absl::StatusOr<std::shared_ptr<const RiskMap>> city =
      MakeDemoCity(DemoCityOptions{.size_m = 1000.0, .res_m = 10.0});
  if (!city.ok()) Fail(city.status().ToString());
  const RiskMap& map = **city;

  v1::EvaluateRiskRequest eval;
  eval.set_map("demo-city");
  *eval.mutable_waypoints()->add_poses() = PoseAt(map, 300, 300, 0.785);
  *eval.mutable_waypoints()->add_poses() = PoseAt(map, 700, 650, 0.785);
  Write(dir, "eval-waypoints", Method('0', eval));
  eval.set_include_samples(true);
  eval.mutable_two_tier()->set_enabled(true);
  eval.mutable_two_tier()->set_bresenham(true);
  Write(dir, "eval-waypoints-samples-two-tier", Method('0', eval));

  v1::EvaluateRiskRequest line;
  line.set_map("demo-city");
  for (const auto& [x, y] : {std::pair{250.0, 300.0}, {500.0, 320.0}, {700.0, 600.0}}) {
    const v1::Pose p = PoseAt(map, x, y, 0.0);
    v1::Point3* point = line.mutable_polyline()->add_points();
    point->set_x(p.x());
    point->set_y(p.y());
    point->set_z(p.z());
  }
  line.mutable_model_params()->set_heading_bins(36);
  line.mutable_model_params()->set_sample_step_m(10.0);
  Write(dir, "eval-polyline-params", Method('0', line));

  v1::PlanRequest plan;
  plan.set_map("demo-city");
  *plan.mutable_start() = PoseAt(map, 300, 300, 0.785);
  *plan.mutable_goal() = PoseAt(map, 700, 700, 0.785);
  plan.mutable_budget()->set_time_ms(20);
  plan.set_seed(7);
  Write(dir, "plan-risk-rrt-star", Method('1', plan));
  plan.set_include_tree(true);
  plan.mutable_budget()->set_time_ms(0);
  plan.mutable_budget()->set_iterations(200);
  Write(dir, "plan-iterations-tree", Method('1', plan));
  plan.set_include_tree(false);
  for (const auto& [name, algorithm] :
       {std::pair{"rrt", v1::RRT}, {"genetic", v1::GENETIC}, {"harmonic", v1::HARMONIC}}) {
    v1::PlanRequest seed = plan;
    seed.set_algorithm(algorithm);
    v1::Point2* obstacle = seed.add_obstacle_points();
    obstacle->set_x(500);
    obstacle->set_y(480);
    if (algorithm == v1::HARMONIC) {
      v1::DynamicObstacle* area = seed.add_dynamic_obstacles();
      area->set_at_iteration(5);
      area->set_x0_m(450);
      area->set_y0_m(450);
      area->set_x1_m(550);
      area->set_y1_m(550);
    }
    Write(dir, std::string("plan-") + name, Method('1', seed));
  }
  v1::PlanRequest params = plan;
  (*params.mutable_planner_params())["goal_bias"] = 0.2;
  params.mutable_model_params()->set_max_agl_m(200.0);
  params.set_min_update_interval_ms(5);
  params.set_display_step_m(5.0);
  Write(dir, "plan-params", Method('1', params));

  // The same requests in WGS84 on "geo-city", the target's geo-referenced
  // copy of the map (its origin at 49.6 N, 6.1 E).
  MapHeader header = map.header();
  header.geo = GeoReference{49.6, 6.1, "azimuthal equidistant on WGS84 at the origin"};
  absl::StatusOr<geo::GeoFrame> frame = geo::FrameOfMap(header);
  if (!frame.ok()) Fail(frame.status().ToString());
  auto to_wgs84 = [&](const v1::Pose& p, v1::GeoPose* out) {
    const Pose local{p.x(), p.y(), p.z(), p.theta()};
    absl::StatusOr<std::vector<geo::GeoPose>> g = frame->ToWgs84(std::span<const Pose>(&local, 1));
    if (!g.ok()) Fail(g.status().ToString());
    out->set_lat_deg((*g)[0].lat_deg);
    out->set_lon_deg((*g)[0].lon_deg);
    out->set_alt_m((*g)[0].alt_m);
    out->set_heading_deg((*g)[0].heading_deg);
  };
  v1::PlanRequest geo_plan;
  geo_plan.set_map("geo-city");
  to_wgs84(PoseAt(map, 300, 300, 0.785), geo_plan.mutable_start_wgs84());
  to_wgs84(PoseAt(map, 700, 700, 0.785), geo_plan.mutable_goal_wgs84());
  geo_plan.mutable_budget()->set_iterations(200);
  geo_plan.set_seed(7);
  Write(dir, "plan-wgs84", Method('1', geo_plan));

  // A fleet ('3'): two missions to one goal (a shared goal tree), one to
  // another goal in WGS84, and one whose start is outside the map.
  v1::FleetRequest fleet;
  fleet.set_tenant("seed");
  fleet.set_send_improvements(true);
  const std::pair<double, double> starts[] = {{250, 300}, {300, 650}};
  for (size_t k = 0; k < 2; ++k) {
    v1::FleetMission* m = fleet.add_missions();
    m->set_id(absl::StrCat("depot-", k));
    m->set_priority(static_cast<int>(10 * k));
    *m->mutable_request() = plan;
    *m->mutable_request()->mutable_start() = PoseAt(map, starts[k].first, starts[k].second, 0.0);
  }
  v1::FleetMission* geo_mission = fleet.add_missions();
  geo_mission->set_id("wgs84");
  *geo_mission->mutable_request() = geo_plan;
  v1::FleetMission* outside = fleet.add_missions();
  outside->set_id("outside");
  *outside->mutable_request() = plan;
  outside->mutable_request()->mutable_start()->set_x(-500.0);
  Write(dir, "fleet", Method('3', fleet));
  v1::EvaluateRiskRequest geo_eval;
  geo_eval.set_map("geo-city");
  to_wgs84(PoseAt(map, 300, 300, 0.785), geo_eval.mutable_waypoints_wgs84()->add_poses());
  to_wgs84(PoseAt(map, 700, 650, 0.785), geo_eval.mutable_waypoints_wgs84()->add_poses());
  geo_eval.set_path_spacing_m(50.0);
  Write(dir, "eval-wgs84-path", Method('0', geo_eval));
}

}  // namespace
}  // namespace riskplan::fuzz

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DIR\n", argv[0]);
    return 2;
  }
  const std::filesystem::path out = argv[1];
  riskplan::fuzz::MapBundleSeeds(out);
  riskplan::fuzz::ShimSessionSeeds(out);
  riskplan::fuzz::ShimClientSeeds(out);
  riskplan::fuzz::RequestSeeds(out);
  return 0;
}
