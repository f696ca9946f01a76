#include "accel/fixed_point.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/check.h"

namespace riskplan::accel {

std::string NumberFormat::Name() const {
  return absl::StrFormat("w%dm%da%d", weight_frac_bits, cell_bits, acc_bits);
}

absl::StatusOr<NumberFormat> NumberFormat::Parse(absl::string_view text) {
  if (text == "board") return Board();
  if (text == "precise") return Precise();
  NumberFormat f;
  if (std::sscanf(std::string(text).c_str(), "w%dm%da%d", &f.weight_frac_bits, &f.cell_bits,
                  &f.acc_bits) != 3 ||
      f.Name() != text) {
    return absl::InvalidArgumentError(absl::StrCat(
        "number format '", text, "' is not of the form wWmMaA (e.g. w32m32a80), board or precise"));
  }
  if (absl::Status s = f.Validate(); !s.ok()) return s;
  return f;
}

absl::Status NumberFormat::Validate() const {
  if (weight_frac_bits < 8 || weight_frac_bits > 48 || cell_bits < 8 || cell_bits > 48 ||
      acc_bits > 128 || acc_bits < weight_frac_bits + cell_bits + 12) {
    return absl::InvalidArgumentError(
        absl::StrCat("number format ", Name(),
                     ": need 8 <= W, M <= 48 and W + M + 12 <= A <= 128 (A holds the exact "
                     "sum of up to 4096 products)"));
  }
  return absl::OkStatus();
}

double FixedPointSumBound(const NumberFormat& format, int exponent, double value_sum, int cells) {
  const double w = std::ldexp(1.0, -format.weight_frac_bits);
  return w * value_sum + std::ldexp(1.0, -(exponent + 1)) * (1.0 + cells * w);
}

int LayerExponent(double max_value, int cell_bits) {
  if (!(max_value > 0.0)) return cell_bits;
  int e = 0;
  std::frexp(max_value, &e);  // max_value = f * 2^e, f in [0.5, 1)
  int exponent = cell_bits - e;
  // max_value * 2^exponent is in [2^(M-1), 2^M); rounding may still reach 2^M.
  if (std::ldexp(max_value, exponent) >= std::ldexp(1.0, cell_bits) - 0.5) --exponent;
  return std::clamp(exponent, -200, 200);
}

uint64_t QuantizeCell(double v, int exponent) {
  RISKPLAN_DCHECK(v >= 0.0 && std::isfinite(v));
  RISKPLAN_DCHECK(std::ldexp(v, exponent) < 0x1p63);
  // v * 2^E is exact (a power-of-two scaling of a float), and so is + 0.5
  // below 2^52.
  return static_cast<uint64_t>(std::floor(std::ldexp(v, exponent) + 0.5));
}

uint64_t QuantizeWeight(double w, int weight_frac_bits) {
  const uint64_t top = (uint64_t{1} << weight_frac_bits) - 1;
  if (!(w > 0.0)) return 0;
  const double q = std::floor(std::ldexp(w, weight_frac_bits) + 0.5);
  if (q >= static_cast<double>(top)) return top;
  return static_cast<uint64_t>(q);
}

double AccumulatorToDouble(Accumulator acc, int scale) {
  // The conversion of a 128-bit integer rounds once, to nearest; the scaling
  // by a power of two is exact (no result here comes near the subnormals).
  return std::ldexp(static_cast<double>(acc), -scale);
}

void AccumulatorToWords(Accumulator acc, uint32_t words[4]) {
  for (int w = 0; w < 4; ++w) words[w] = static_cast<uint32_t>(acc >> (32 * w));
}

Accumulator AccumulatorFromWords(const uint32_t words[4]) {
  Accumulator acc = 0;
  for (int w = 3; w >= 0; --w) acc = (acc << 32) | words[w];
  return acc;
}

uint64_t QuantizedMap::DensityAt(int i, int j) const {
  if (i < -pad || j < -pad || i >= nx + pad || j >= ny + pad) return outside_density;
  return density[static_cast<size_t>(j + pad) * padded_nx() + (i + pad)];
}

uint64_t QuantizedMap::ShelterAt(int i, int j) const {
  if (i < -pad || j < -pad || i >= nx + pad || j >= ny + pad) return outside_shelter;
  return shelter[static_cast<size_t>(j + pad) * padded_nx() + (i + pad)];
}

QuantizedMap QuantizeMap(int nx, int ny, const float* density, const float* shelter,
                         const NumberFormat& format, int pad) {
  QuantizedMap q;
  q.nx = nx;
  q.ny = ny;
  q.pad = pad;
  const size_t cells = static_cast<size_t>(nx) * ny;
  // Out-of-map cells read density 0 and shelter 10 (spec): 10 belongs to the
  // shelter layer's range.
  double max_density = 0.0;
  double max_shelter = 10.0;
  for (size_t c = 0; c < cells; ++c) {
    max_density = std::max(max_density, static_cast<double>(density[c]));
    max_shelter = std::max(max_shelter, static_cast<double>(shelter[c]));
  }
  q.density_exponent = LayerExponent(max_density, format.cell_bits);
  q.shelter_exponent = LayerExponent(max_shelter, format.cell_bits);
  q.outside_density = QuantizeCell(0.0, q.density_exponent);
  q.outside_shelter = QuantizeCell(10.0, q.shelter_exponent);
  const size_t padded = static_cast<size_t>(nx + 2 * pad) * (ny + 2 * pad);
  q.density.assign(padded, q.outside_density);
  q.shelter.assign(padded, q.outside_shelter);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const size_t src = static_cast<size_t>(j) * nx + i;
      const size_t dst = static_cast<size_t>(j + pad) * q.padded_nx() + (i + pad);
      q.density[dst] = QuantizeCell(density[src], q.density_exponent);
      q.shelter[dst] = QuantizeCell(shelter[src], q.shelter_exponent);
    }
  }
  return q;
}

void ModelEwmm(const QuantizedMap& map, const QuantizedKernel& kernel, int ci, int cj,
               Accumulator* impact, Accumulator* shelter) {
  const int hw = kernel.half_width;
  const int side = kernel.Side();
  Accumulator acc_density = 0;
  Accumulator acc_shelter = 0;
  const bool inside = ci - hw >= -map.pad && cj - hw >= -map.pad && ci + hw < map.nx + map.pad &&
                      cj + hw < map.ny + map.pad;
  for (int v = 0; v < side; ++v) {
    const uint64_t* w = kernel.weights.data() + static_cast<size_t>(v) * side;
    if (inside) {
      const size_t row =
          static_cast<size_t>(cj - hw + v + map.pad) * map.padded_nx() + (ci - hw + map.pad);
      const uint64_t* d = map.density.data() + row;
      const uint64_t* s = map.shelter.data() + row;
      for (int u = 0; u < side; ++u) {
        acc_density += static_cast<Accumulator>(w[u]) * d[u];
        acc_shelter += static_cast<Accumulator>(w[u]) * s[u];
      }
    } else {
      for (int u = 0; u < side; ++u) {
        acc_density += static_cast<Accumulator>(w[u]) * map.DensityAt(ci - hw + u, cj - hw + v);
        acc_shelter += static_cast<Accumulator>(w[u]) * map.ShelterAt(ci - hw + u, cj - hw + v);
      }
    }
  }
  *impact = acc_density;
  *shelter = acc_shelter;
}

}  // namespace riskplan::accel
