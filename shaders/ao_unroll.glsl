// The sample loop of an AO pass, as straight-line code: expands AO_SAMPLE(i) for
// i = 0 .. AO_SAMPLES - 1, with i a constant, by the binary digits of AO_SAMPLES. The including
// shader defines AO_SAMPLE(i) (one sample's work, a statement) and includes this file where the
// loop would be. Above AO_UNROLL_MAX samples it stays a loop: llvmpipe compiles a shader on its
// first draw, which took 1.1 s unrolled at 128 samples and 12.6 s at 512.
//
// Why: llvmpipe runs a loop over SIMD lanes with execution masks and keeps its state in memory
// across iterations; fully unrolled, the same shader took 13-15 % less time (vector, 32 samples,
// 1024x768, the AO bit for bit the same). Partly unrolled loops were no faster (by 4) or slower
// (by 16), so it is all or nothing. The fetch floor is unrolled the same way, so its ratio
// still compares like with like.
#define AO_UNROLL_MAX 128
#if AO_SAMPLES > AO_UNROLL_MAX
    for (int i = 0; i < AO_SAMPLES; ++i) { AO_SAMPLE(i) }
#else
#define AO_R1(i) AO_SAMPLE(i)
#define AO_R2(i) AO_R1(i) AO_R1((i) + 1)
#define AO_R4(i) AO_R2(i) AO_R2((i) + 2)
#define AO_R8(i) AO_R4(i) AO_R4((i) + 4)
#define AO_R16(i) AO_R8(i) AO_R8((i) + 8)
#define AO_R32(i) AO_R16(i) AO_R16((i) + 16)
#define AO_R64(i) AO_R32(i) AO_R32((i) + 32)
#define AO_R128(i) AO_R64(i) AO_R64((i) + 64)
#if AO_SAMPLES & 128
    AO_R128(0)
#endif
#if AO_SAMPLES & 64
    AO_R64(AO_SAMPLES & 896)
#endif
#if AO_SAMPLES & 32
    AO_R32(AO_SAMPLES & 960)
#endif
#if AO_SAMPLES & 16
    AO_R16(AO_SAMPLES & 992)
#endif
#if AO_SAMPLES & 8
    AO_R8(AO_SAMPLES & 1008)
#endif
#if AO_SAMPLES & 4
    AO_R4(AO_SAMPLES & 1016)
#endif
#if AO_SAMPLES & 2
    AO_R2(AO_SAMPLES & 1020)
#endif
#if AO_SAMPLES & 1
    AO_R1(AO_SAMPLES & 1022)
#endif
#endif
