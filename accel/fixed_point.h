// The fixed-point number format of the FPGA component's EWMM datapath, and a
// bit-exact software model of that datapath (docs/accel.md has the format,
// the rounding rules and the error bound).
//
//   weight   w in [0, 1]  ->  q_w = min(round(w * 2^W), 2^W - 1)     (UQ0.W)
//   cell     v >= 0       ->  q_v = round(v * 2^E)  < 2^M             (M-bit, per-layer exponent E)
//   product  q_w * q_v   exact, < 2^(W+M)
//   sum      of at most 4096 products, exact in an A-bit accumulator, A >= W+M+12
//   value    I = acc * 2^-(W+E_density), S~ = acc * 2^-(W+E_shelter)
// round(x) = floor(x + 0.5). E of a layer is the largest exponent for which
// the layer's largest value still fits M bits (LayerExponent). Because every
// product and every sum is exact, the order of accumulation does not matter:
// a streaming RTL that adds the products in any order gives the same bits.
//
// The only errors against double are the quantisation of the inputs:
//   |I^ - I| <= 2^-W * sum(rho) + 2^-(E_density+1) * (1 + N * 2^-W)
// for a window of N cells (likewise for S~), plus one rounding of the final
// conversion to double (2^-53 relative).
#ifndef RISKPLAN_ACCEL_FIXED_POINT_H_
#define RISKPLAN_ACCEL_FIXED_POINT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace riskplan::accel {

// An exact unsigned accumulator (the model keeps A <= 128 bits).
using Accumulator = unsigned __int128;

struct NumberFormat {
  int weight_frac_bits = 32;  // W
  int cell_bits = 32;         // M
  int acc_bits = 80;          // A (the thesis's component used 80-bit UQ16.64)

  // The format of the DE10-Nano component (32 x 32 -> 80 bits: one 27x27
  // plus partial DSP products per lane on a Cyclone V).
  static NumberFormat Board() { return {32, 32, 80}; }
  // A format whose error is far below any comparison the planner makes
  // (about 1e-13 relative), for checking that plans match the CPU path.
  static NumberFormat Precise() { return {48, 48, 128}; }

  // "w32m32a80".
  std::string Name() const;
  // Parses Name()'s form; also "board" and "precise".
  static absl::StatusOr<NumberFormat> Parse(absl::string_view text);
  // 8 <= W, M <= 48 and W + M + 12 <= A <= 128.
  absl::Status Validate() const;

  bool operator==(const NumberFormat&) const = default;
};

// Largest number of cells a window may have (a side of 64): it bounds the
// accumulator growth to 12 bits.
inline constexpr int kMaxWindowCells = 64 * 64;

// The exponent E of a layer whose largest value is `max_value` (>= 0):
// the largest E with round(max_value * 2^E) < 2^cell_bits, clamped to
// [-200, 200]; cell_bits for an all-zero layer.
int LayerExponent(double max_value, int cell_bits);

// The documented bound of |board sum - exact sum| for one layer of a window
// of `cells` cells whose values add up to `value_sum` (>= 0), the layer
// quantised with `exponent`:
//   2^-W * value_sum + 2^-(exponent+1) * (1 + cells * 2^-W)
// (the conversion to double adds at most 2^-53 relative on top).
double FixedPointSumBound(const NumberFormat& format, int exponent, double value_sum, int cells);

// q = round(v * 2^exponent), v >= 0 finite. REQUIRES: the result fits 63 bits.
uint64_t QuantizeCell(double v, int exponent);
// q_w = min(round(w * 2^W), 2^W - 1), w in [0, 1].
uint64_t QuantizeWeight(double w, int weight_frac_bits);
// acc * 2^-scale, rounded once to the nearest double.
double AccumulatorToDouble(Accumulator acc, int scale);

// Splits an accumulator into 32-bit words, least significant first (as the
// component's result registers and the shim protocol carry it).
void AccumulatorToWords(Accumulator acc, uint32_t words[4]);
Accumulator AccumulatorFromWords(const uint32_t words[4]);

// A map quantised for the datapath: both layers with a border of `pad` cells
// holding density 0 and shelter 10, so that any window within `pad` of the map
// reads without checks. The server sends a board only sites whose windows lie
// inside the map (spec version 2), so the border is read by the RTL's and the
// model's checks of every edge, never for a risk the engine reports.
struct QuantizedMap {
  int nx = 0;
  int ny = 0;
  int pad = 0;
  int density_exponent = 0;
  int shelter_exponent = 0;
  std::vector<uint64_t> density;  // (nx + 2 pad) x (ny + 2 pad), row-major
  std::vector<uint64_t> shelter;
  uint64_t outside_density = 0;  // quantised 0
  uint64_t outside_shelter = 0;  // quantised 10

  int padded_nx() const { return nx + 2 * pad; }
  // Quantised values of cell (i, j), which may lie anywhere.
  uint64_t DensityAt(int i, int j) const;
  uint64_t ShelterAt(int i, int j) const;
  size_t MemoryBytes() const { return (density.size() + shelter.size()) * sizeof(uint64_t); }
};

// Quantises float layers of nx * ny cells (row-major, row 0 south).
QuantizedMap QuantizeMap(int nx, int ny, const float* density, const float* shelter,
                         const NumberFormat& format, int pad);

// One quantised kernel: side x side weights, row-major, rows running north.
struct QuantizedKernel {
  int half_width = 0;
  std::vector<uint64_t> weights;
  int Side() const { return 2 * half_width + 1; }
};

// The datapath: the exact sums of q_w * q_cell over the window of `kernel`
// centred on cell (ci, cj).
void ModelEwmm(const QuantizedMap& map, const QuantizedKernel& kernel, int ci, int cj,
               Accumulator* impact, Accumulator* shelter);

}  // namespace riskplan::accel

#endif  // RISKPLAN_ACCEL_FIXED_POINT_H_
