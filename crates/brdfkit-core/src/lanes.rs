//! Loops over slices compiled for the widest vector instructions the processor has.
//!
//! A loop written as branch-free code over plain slices implements [`Run`];
//! [`dispatch`] runs it in a copy compiled for AVX-512 or AVX2 + FMA when the processor
//! has them, chosen at run time (`is_x86_feature_detected!`): the crates are compiled
//! for baseline x86-64 (SSE2: 2 `f64` lanes). Rust never contracts `a * b + c` into a
//! fused multiply-add, and IEEE operations and integer arithmetic give the same bits in
//! every lane width, so every copy computes the same bits as the baseline loop and as a
//! scalar call of the same code: a vectorised path needs no tolerance.

/// A loop over slices, run by [`dispatch`].
pub trait Run {
    /// The loop. Implementations mark it `#[inline(always)]`, so each copy made by
    /// [`dispatch`] is compiled with that copy's instruction set.
    fn run(&mut self);
}

/// Runs `r` with AVX-512 (F + VL + DQ: DQ converts between f64 and 64-bit integers in
/// vectors, which bin indexing needs), else AVX2 + FMA, else the baseline instructions.
#[inline]
pub fn dispatch<R: Run>(r: &mut R) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx512dq")
        {
            // SAFETY: the instruction sets the copy is compiled for are present.
            return unsafe { run_avx512(r) };
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: as above.
            return unsafe { run_avx2(r) };
        }
    }
    r.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
fn run_avx512<R: Run>(r: &mut R) {
    r.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn run_avx2<R: Run>(r: &mut R) {
    r.run()
}
