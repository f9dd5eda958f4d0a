// AVX2_CLONE: an AVX2 copy of a hot function beside the portable one, chosen once by the CPU when the library loads
// (GCC and Clang on x86-64 Linux: target_clones, an ifunc).  The numbers are the same bits in both: AVX2 has no
// fused multiply-add (FMA is a feature of its own, not asked for) and the compiler never reorders floating-point
// sums (no -ffast-math), so only the registers change: three-operand instructions spare the copies SSE2 makes.
// ALWAYS_INLINE and FLATTEN (every call inside inlined): a step compiled into each copy of its caller, for that
// copy's CPU.  Used where it was measured to pay: the forward dynamics derivatives' passes (aba_derivatives.hpp),
// RNEA (rnea.cpp) and the CRBA (crba.cpp); the inverse dynamics derivatives ran fewer instructions as an AVX2 copy
// but were not faster, so they have none.
#pragma once

// -DDYNAMICS_PORTABLE_ONLY: the portable copies alone (to check that both copies give the same bits).
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(DYNAMICS_PORTABLE_ONLY)
#define AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#define HAVE_AVX2_CLONES 1
#else
#define AVX2_CLONE
#define HAVE_AVX2_CLONES 0
#endif

#if defined(__GNUC__)
#define ALWAYS_INLINE inline __attribute__((always_inline))
#define FLATTEN __attribute__((flatten))
#else
#define ALWAYS_INLINE inline
#define FLATTEN
#endif
