// Type-1 NUFFT spreading on the CPU, as an XLA FFI handler (sarjax._numerics.native).
//
// out[(⌈t_P − w/2⌉ + i) mod G] += a_P ψ_i(f_P),  f_P = ⌈t_P − w/2⌉ − (t_P − w/2) ∈ [0, 1),
// the w taps ψ_i polynomials of degree w + 1 in f (es_kernel.spreading_kernel), a point
// at grid position t_P [cells] and complex amplitude a_P. The same sum as the JAX
// reference simulators._nufft._spread_xla, with the same clamping of a start cell to
// [−low, G + low] (points that far out carry zero amplitude) and the same precision: f
// from the float64 position, the weights and products in the amplitude's precision.
//
// Points are taken in blocks: the fractions and first cells of a block, then each tap's
// weights over the block (loops the compiler vectorises), then one pass adding the w
// products of each point into an extended grid whose ends are folded at the end.

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <vector>

#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

namespace {

constexpr int64_t kBlock = 256;

template <typename Real, int W>
void SpreadBlocks(const double* points, const Real* amplitude, const Real* coefficients,
                  int64_t n, int64_t grid, int64_t low, Real* extended) {
  constexpr int D = W + 1;  // polynomial degree
  alignas(64) Real fraction[kBlock];
  alignas(64) Real weight[W][kBlock];
  alignas(64) int32_t first[kBlock];
  Real c[W][D + 1];
  for (int i = 0; i < W; ++i)
    for (int k = 0; k <= D; ++k) c[i][k] = coefficients[k * W + i];
  const double lowest = -static_cast<double>(low);
  const double highest = static_cast<double>(grid + low);
  const int32_t offset = static_cast<int32_t>(low);
  for (int64_t m0 = 0; m0 < n; m0 += kBlock) {
    const int64_t b = std::min(kBlock, n - m0);
    const double* t = points + m0;
    for (int64_t j = 0; j < b; ++j) {
      const double shifted = t[j] - 0.5 * W;
      const double start = std::ceil(shifted);
      fraction[j] = static_cast<Real>(start - shifted);
      // clamped to [−low, G + low]; a NaN position goes to −low (comparisons with NaN
      // are false), so that no write leaves the extended grid
      const double above = start > lowest ? start : lowest;
      first[j] = static_cast<int32_t>(above < highest ? above : highest) + offset;
    }
    for (int i = 0; i < W; ++i) {
      for (int64_t j = 0; j < b; ++j) {
        Real value = c[i][D];
#pragma GCC unroll 32
        for (int k = D - 1; k >= 0; --k) value = value * fraction[j] + c[i][k];
        weight[i][j] = value;
      }
    }
    const Real* a = amplitude + 2 * m0;
    for (int64_t j = 0; j < b; ++j) {
      Real* cell = extended + 2 * static_cast<int64_t>(first[j]);
      const Real re = a[2 * j], im = a[2 * j + 1];
#pragma GCC unroll 16
      for (int i = 0; i < W; ++i) {
        cell[2 * i] += re * weight[i][j];
        cell[2 * i + 1] += im * weight[i][j];
      }
    }
  }
}

template <typename Real>
bool Dispatch(int64_t width, const double* points, const Real* amplitude,
              const Real* coefficients, int64_t n, int64_t grid, int64_t low, Real* extended) {
  switch (width) {
#define SARJAX_WIDTH(W)                                                                   \
  case W:                                                                                 \
    SpreadBlocks<Real, W>(points, amplitude, coefficients, n, grid, low, extended);       \
    return true;
    SARJAX_WIDTH(2) SARJAX_WIDTH(3) SARJAX_WIDTH(4) SARJAX_WIDTH(5) SARJAX_WIDTH(6)
    SARJAX_WIDTH(7) SARJAX_WIDTH(8) SARJAX_WIDTH(9) SARJAX_WIDTH(10) SARJAX_WIDTH(11)
    SARJAX_WIDTH(12) SARJAX_WIDTH(13) SARJAX_WIDTH(14) SARJAX_WIDTH(15) SARJAX_WIDTH(16)
#undef SARJAX_WIDTH
    default:
      return false;
  }
}

template <typename Real, ffi::DataType RealType, ffi::DataType ComplexType>
ffi::Error Spread(ffi::Buffer<ffi::F64> points, ffi::Buffer<ComplexType> amplitude,
                  ffi::Buffer<RealType> coefficients, ffi::ResultBuffer<ComplexType> out,
                  int64_t grid, int64_t low) {
  using Complex = std::complex<Real>;
  const int64_t n = static_cast<int64_t>(points.element_count());
  const auto shape = coefficients.dimensions();
  if (shape.size() != 2 || shape[0] != shape[1] + 2)
    return ffi::Error::InvalidArgument("coefficients must be (width + 2, width)");
  if (static_cast<int64_t>(amplitude.element_count()) != n)
    return ffi::Error::InvalidArgument("points and amplitude differ in length");
  const int64_t width = shape[1];
  if (grid < 1 || low < 0 || static_cast<int64_t>(out->element_count()) != grid ||
      grid + 2 * low + width > INT32_MAX)
    return ffi::Error::InvalidArgument("grid or low out of range");
  const int64_t length = grid + 2 * low + width;  // cells −low … G + low + w − 1
  std::vector<Real> extended(2 * length, Real(0));
  if (!Dispatch<Real>(width, points.typed_data(),
                      reinterpret_cast<const Real*>(amplitude.typed_data()),
                      coefficients.typed_data(), n, grid, low, extended.data()))
    return ffi::Error::InvalidArgument("width must be 2 … 16");
  // extended cell j is grid cell j − low, folded onto the periodic grid
  const Complex* x = reinterpret_cast<const Complex*>(extended.data());
  Complex* o = reinterpret_cast<Complex*>(out->typed_data());
  std::fill(o, o + grid, Complex(0));
  int64_t cell = ((-low) % grid + grid) % grid;
  for (int64_t j = 0; j < length; ++j) {
    o[cell] += x[j];
    if (++cell == grid) cell = 0;
  }
  return ffi::Error::Success();
}

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(
    sarjax_spread_c64, (Spread<float, ffi::F32, ffi::C64>),
    ffi::Ffi::Bind()
        .Arg<ffi::Buffer<ffi::F64>>()
        .Arg<ffi::Buffer<ffi::C64>>()
        .Arg<ffi::Buffer<ffi::F32>>()
        .Ret<ffi::Buffer<ffi::C64>>()
        .Attr<int64_t>("grid")
        .Attr<int64_t>("low"));

XLA_FFI_DEFINE_HANDLER_SYMBOL(
    sarjax_spread_c128, (Spread<double, ffi::F64, ffi::C128>),
    ffi::Ffi::Bind()
        .Arg<ffi::Buffer<ffi::F64>>()
        .Arg<ffi::Buffer<ffi::C128>>()
        .Arg<ffi::Buffer<ffi::F64>>()
        .Ret<ffi::Buffer<ffi::C128>>()
        .Attr<int64_t>("grid")
        .Attr<int64_t>("low"));
