//! Instruction-set detection and dispatch.

/// An instruction set a kernel is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64, or any other architecture).
    Baseline,
    /// x86-64 with AVX2 and FMA, and the bit instructions every such CPU has (BMI1, BMI2,
    /// LZCNT, POPCNT: lane masks are counted and scanned with them). Kernels for it are
    /// compiled with `#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]`.
    Avx2,
    /// [`Isa::Avx2`] and AVX-512 (F, VL, DQ, BW): `#[target_feature(enable =
    /// "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]`.
    Avx512,
}

impl Isa {
    /// Every variant, fastest first.
    pub const ALL: [Isa; 3] = [Isa::Avx512, Isa::Avx2, Isa::Baseline];

    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// Whether this CPU runs the variant.
    pub fn supported(self) -> bool {
        match self {
            Isa::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("bmi1")
                    && std::arch::is_x86_feature_detected!("bmi2")
                    && std::arch::is_x86_feature_detected!("lzcnt")
                    && std::arch::is_x86_feature_detected!("popcnt")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512bw")
                    && Isa::Avx2.supported()
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The fastest variant this CPU runs (cached by the standard library's feature detection).
    pub fn detect() -> Isa {
        Isa::ALL
            .into_iter()
            .find(|isa| isa.supported())
            .unwrap_or(Isa::Baseline)
    }
}

/// A variant by its [`Isa::name`] (the benchmarks' `…_ISA` variables). Whether the CPU runs it
/// is the caller's check ([`Isa::supported`]).
impl std::str::FromStr for Isa {
    type Err = String;

    fn from_str(name: &str) -> Result<Isa, String> {
        Isa::ALL
            .into_iter()
            .find(|isa| isa.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = Isa::ALL.iter().map(|isa| isa.name()).collect();
                format!(
                    "unknown kernel variant '{name}' (expected one of: {})",
                    names.join(", ")
                )
            })
    }
}

/// A kernel and its arguments: [`dispatch`] compiles [`Kernel::run`] once per [`Isa`].
///
/// `run` must be `#[inline(always)]`, and so must what it calls down to the vectorised loops:
/// code that is not inlined into the variant is compiled for the baseline only.
pub trait Kernel {
    type Output;
    fn run(self) -> Self::Output;
}

/// `kernel.run()` compiled for `isa` (its code inlined into a function with that instruction
/// set's target features), or for the baseline when `isa` is the baseline or this CPU lacks it.
#[inline]
pub fn dispatch<K: Kernel>(isa: Isa, kernel: K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(
            enable = "avx512f,avx512vl,avx512dq,avx512bw,avx2,fma,bmi1,bmi2,lzcnt,popcnt"
        )]
        unsafe fn avx512<K: Kernel>(kernel: K) -> K::Output {
            kernel.run()
        }
        #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
        unsafe fn avx2<K: Kernel>(kernel: K) -> K::Output {
            kernel.run()
        }
        if isa == Isa::Avx512 && isa.supported() {
            // SAFETY: the features the function is compiled for were just detected.
            return unsafe { avx512(kernel) };
        }
        if isa == Isa::Avx2 && isa.supported() {
            // SAFETY: as above.
            return unsafe { avx2(kernel) };
        }
    }
    let _ = isa;
    kernel.run()
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Sum<'a>(&'a [f32; 16]);
    impl Kernel for Sum<'_> {
        type Output = f32;
        #[inline(always)]
        fn run(self) -> f32 {
            self.0.iter().sum()
        }
    }

    #[test]
    fn every_supported_variant_runs_the_kernel() {
        let v: [f32; 16] = std::array::from_fn(|i| i as f32);
        for isa in Isa::ALL {
            assert_eq!(dispatch(isa, Sum(&v)), 120.0, "{isa:?}");
        }
        assert!(Isa::Baseline.supported());
        assert!(Isa::detect().supported());
    }

    #[test]
    fn isa_names_parse_back() {
        for isa in Isa::ALL {
            assert_eq!(isa.name().parse::<Isa>(), Ok(isa));
        }
        let err = "sse4".parse::<Isa>().unwrap_err();
        assert!(
            err.contains("'sse4'") && err.contains("avx512, avx2, baseline"),
            "{err}"
        );
    }
}
