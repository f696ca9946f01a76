// Pictures of a plan: the map's population density (log colour scale), its
// no-fly zones and landing sites, the planner's tree, every improved
// trajectory (older ones lighter), and the start and goal; a caption above
// the map, and under it a legend (the density scale with its decades in
// people per m², a key to every colour and marker, and a scale bar of a
// round number of metres). client/picture/picture_layout.h places each part.
//
// Written as SVG (the density raster embedded as a PNG, the trajectories and
// the legend as vector elements) or as a plain PNG (the legend's text in a
// built-in bitmap font), chosen by the file name's extension.
#ifndef RISKPLAN_CLIENT_PICTURE_PICTURE_H_
#define RISKPLAN_CLIENT_PICTURE_PICTURE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "riskplan/v1/planner.pb.h"

namespace riskplan::client {

struct PictureInput {
  v1::MapInfo map;                           // landing sites
  v1::GetMapLayerResponse density;           // POPULATION_DENSITY, sets the picture's grid
  v1::GetMapLayerResponse nofly;             // NO_FLY on the same grid (may be empty)
  std::vector<v1::Trajectory> improvements;  // in the order found; the last is drawn boldest
  std::vector<v1::TreeEdge> tree;            // may be empty
  v1::Pose start;
  v1::Pose goal;
  // A fleet (riskplan fleet): every mission's final trajectory, each drawn
  // as a final one, with its label (the mission id) as its SVG tooltip, and
  // every mission's start, drawn as `start` is. Empty for a single plan.
  std::vector<v1::Trajectory> fleet;
  std::vector<std::string> fleet_labels;  // one per fleet trajectory
  std::vector<v1::Pose> fleet_starts;
  std::string caption;  // text above the map, word-wrapped to the picture's width
  // The mean wind (the answer's echo): when its speed is above 0, an arrow
  // in the map's top-right corner points where the air moves to, with the
  // speed and the direction it blows from written under it.
  v1::WindReport wind;
  // Draw each fleet trajectory in its own colour (FleetColour) with a key of
  // their labels in the map's top-left corner, rather than all alike: for a
  // few routes to compare (scripts/wind-demo.sh).
  bool fleet_key = false;
};

// An RGBA image, row 0 at the top.
struct RgbaImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> pixels;  // width * height * 4
};

// Encodes `image` as PNG.
// REQUIRES: image.pixels.size() == image.width * image.height * 4.
absl::StatusOr<std::string> EncodePng(const RgbaImage& image);

// The map layers alone: density colours with the no-fly zones tinted violet.
// REQUIRES: input.density holds nx * ny values (WritePicture checks it).
RgbaImage RenderMapRaster(const PictureInput& input);

// The PNG picture: caption, map (one pixel per layer cell) with everything
// drawn on it, and legend, where LayoutPicture(input) places them.
// REQUIRES: input.density holds nx * ny values (WritePicture checks it).
RgbaImage RenderPicture(const PictureInput& input);

// The SVG document, laid out as RenderPicture's.
// REQUIRES: input.density holds nx * ny values (WritePicture checks it).
std::string RenderSvg(const PictureInput& input);

// Writes `input` to `path`: SVG when it ends in ".svg", PNG when it ends in
// ".png"; InvalidArgument otherwise, and for a density layer that is empty or
// does not hold nx * ny values.
absl::Status WritePicture(const std::string& path, const PictureInput& input);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_PICTURE_PICTURE_H_
