// AVX2_CLONE: an AVX2 copy of a hot function beside the portable one, chosen once by the CPU when the library loads
// (GCC and Clang on x86-64 Linux: target_clones, an ifunc).  The numbers are the same bits in both: AVX2 has no
// fused multiply-add (FMA is a feature of its own, not asked for) and the compiler never reorders floating-point
// sums (no -ffast-math), so only the registers change: three-operand instructions spare the copies SSE2 makes.
// ALWAYS_INLINE and FLATTEN (every call inside inlined): a step compiled into each copy of its caller, for that
// copy's CPU.  Used where it was measured to pay: the forward dynamics derivatives' passes (aba_derivatives.hpp),
// RNEA (rnea.cpp) and the CRBA (crba.cpp); the inverse dynamics derivatives ran fewer instructions as an AVX2 copy
// but were not faster, so they have none.
// AVX512_CLONE adds an AVX-512F copy (RNEA, CRBA): their steps are scalar 3-vector arithmetic, which AVX-512F's 32
// registers (xmm16-31) keep out of the stack the 16 of AVX2 spill to (RNEA 7 % faster on Panda and UR5, one
// thread, alternated).  AVX-512F does have fused multiply-add instructions, but the compiler only makes them by
// contracting a * b + c, which -ffp-contract=off forbids (CMakeLists.txt): the module has no vfmadd instruction,
// and the outputs are the same bits as the portable copy's (checked with -DDYNAMICS_PORTABLE_ONLY).
#pragma once

// -DDYNAMICS_PORTABLE_ONLY: the portable copies alone (to check that both copies give the same bits).
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__) && !defined(DYNAMICS_PORTABLE_ONLY)
#define AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#define AVX512_CLONE __attribute__((target_clones("avx512f", "avx2", "default")))
#define HAVE_AVX2_CLONES 1
#else
#define AVX2_CLONE
#define AVX512_CLONE
#define HAVE_AVX2_CLONES 0
#endif

#if defined(__GNUC__)
#define ALWAYS_INLINE inline __attribute__((always_inline))
#define FLATTEN __attribute__((flatten))
#else
#define ALWAYS_INLINE inline
#define FLATTEN
#endif
