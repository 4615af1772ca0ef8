//! The vector instruction sets the hot loops are built for, picked at run time: the wheel is
//! built for the baseline target (no `target-cpu=native`), and the shield's composite kernel,
//! the LIDAR's indexed scan and the noise draws each have an AVX2+FMA and an AVX-512 build of
//! the same code, giving the same numbers (no fused multiply-add is asked for).

/// Instruction-set level a kernel runs at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimdLevel {
    /// The baseline target (SSE2 on x86-64): portable, slowest.
    Portable,
    /// x86-64 AVX2 + FMA.
    Avx2,
    /// x86-64 AVX-512 (F, VL, DQ) with AVX2 + FMA.
    Avx512,
}

impl SimdLevel {
    /// The best level this CPU supports.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx2") && has!("fma") {
                if has!("avx512f") && has!("avx512vl") && has!("avx512dq") {
                    return SimdLevel::Avx512;
                }
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Portable
    }

    /// Whether this CPU can run `self`.
    pub fn is_supported(self) -> bool {
        match self {
            SimdLevel::Portable => true,
            SimdLevel::Avx2 => matches!(Self::detect(), SimdLevel::Avx2 | SimdLevel::Avx512),
            SimdLevel::Avx512 => Self::detect() == SimdLevel::Avx512,
        }
    }
}
