// Private to piv: which SIMD kernels this CPU runs (checked once, at run time).
#pragma once

namespace shearzone::piv::detail {

#if defined(__x86_64__)
/// AVX2 and FMA: the deformation and correlation kernels' instruction sets.
inline bool cpu_has_avx2_fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

}  // namespace shearzone::piv::detail
