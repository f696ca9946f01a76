// The caption and the legend of a plan's picture, placed by
// client/picture/picture_layout.h: drawn into the PNG, or written as SVG elements.
#ifndef RISKPLAN_CLIENT_PICTURE_PICTURE_LEGEND_H_
#define RISKPLAN_CLIENT_PICTURE_PICTURE_LEGEND_H_

#include <cstddef>
#include <string>

#include "client/picture/picture.h"
#include "client/picture/picture_layout.h"

namespace riskplan::client {

// Draws the caption, the density scale, the keys and the scale bar of
// `layout` into `img`, the whole picture. `improvements` is how many
// improvements the map shows (their keys take its colours).
// REQUIRES: img is layout.width x layout.height.
void DrawCaptionAndLegend(RgbaImage* img, const PictureLayout& layout, size_t improvements);

// The same as SVG elements, for a document whose user units are the
// layout's pixels.
std::string SvgCaptionAndLegend(const PictureLayout& layout, size_t improvements);

}  // namespace riskplan::client

#endif  // RISKPLAN_CLIENT_PICTURE_PICTURE_LEGEND_H_
