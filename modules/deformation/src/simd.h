#pragma once
#include <atomic>
// Four-double rows for the posing kernels: with AVX2 one row is one register. Kernels are written
// once with GCC/Clang vector extensions and compiled twice (AVX2+FMA and the baseline), chosen at
// run time, so the binary still runs on any x86-64.
namespace posekit::simd {

typedef double Double4 __attribute__((vector_size(32)));
/// The same for data only 8-byte (4-byte) aligned.
typedef double Double4u __attribute__((vector_size(32), aligned(8)));
typedef float Float8u __attribute__((vector_size(32), aligned(4)));

/// use_avx2_kernels() (poisson_solver.h) switches the AVX2 kernels off for tests.
extern std::atomic<bool> avx2_allowed;

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define POSEKIT_TARGET_AVX2 __attribute__((target("avx2,fma")))
inline bool cpu_has_avx2() {
  static const bool yes = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return yes;
}
#else
#define POSEKIT_TARGET_AVX2
inline bool cpu_has_avx2() { return false; }
#endif
inline bool has_avx2() { return cpu_has_avx2() && avx2_allowed.load(std::memory_order_relaxed); }

}  // namespace posekit::simd
