//! Whether the CPU runs AVX2, asked of the CPU itself (`cpuid`, `xgetbv`), so the
//! no_std core picks the same wider code path the std library's detection would. The
//! AVX2 path performs the same operations on every element (Rust never contracts
//! `a * b + c` into a fused multiply-add), so both paths give the same bits.

/// True when this x86-64 CPU and its OS support AVX2 (the answer is cached).
#[cfg(all(target_arch = "x86_64", not(miri)))]
pub fn has_avx2() -> bool {
    use core::sync::atomic::{AtomicU8, Ordering};
    /// 0: not asked yet, 1: no, 2: yes.
    static KNOWN: AtomicU8 = AtomicU8::new(0);
    match KNOWN.load(Ordering::Relaxed) {
        1 => false,
        2 => true,
        _ => {
            let yes = detect_avx2();
            KNOWN.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
            yes
        }
    }
}

/// Under Miri, which cannot run `cpuid` or `xgetbv`: the build's target features
/// answer. A plain Miri run takes the portable path; `tools/miri` runs the suite again
/// built with `-Ctarget-feature=+avx2,+fma`, through the AVX2 path (Miri refuses a call
/// of a `target_feature` function the build does not enable, so that run checks every
/// such call's safety condition too).
#[cfg(all(target_arch = "x86_64", miri))]
pub fn has_avx2() -> bool {
    cfg!(target_feature = "avx2")
}

/// No AVX2 off x86-64.
#[cfg(not(target_arch = "x86_64"))]
pub fn has_avx2() -> bool {
    false
}

#[cfg(all(target_arch = "x86_64", not(miri)))]
#[allow(unused_unsafe)]
fn detect_avx2() -> bool {
    use core::arch::x86_64::{__cpuid, __cpuid_count};
    // SAFETY: every x86-64 CPU has cpuid.
    let max_leaf = unsafe { __cpuid(0) }.eax;
    // SAFETY: as above.
    let leaf1 = unsafe { __cpuid(1) };
    let osxsave = leaf1.ecx & (1 << 27) != 0;
    let avx = leaf1.ecx & (1 << 28) != 0;
    if max_leaf < 7 || !osxsave || !avx {
        return false;
    }
    // SAFETY: leaf 7 exists (max_leaf ≥ 7).
    let leaf7 = unsafe { __cpuid_count(7, 0) };
    if leaf7.ebx & (1 << 5) == 0 {
        return false;
    }
    // SAFETY: OSXSAVE is set, so the OS has enabled xgetbv.
    let xcr0 = unsafe { xgetbv0() };
    // The OS saves the SSE and AVX (YMM) registers across context switches.
    xcr0 & 0b110 == 0b110
}

/// XCR0, the OS's enabled register states.
#[cfg(all(target_arch = "x86_64", not(miri)))]
#[target_feature(enable = "xsave")]
/// # Safety
/// The CPU must support xsave and the OS must have enabled it (OSXSAVE set).
unsafe fn xgetbv0() -> u64 {
    core::arch::x86_64::_xgetbv(0)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn agrees_with_the_std_library() {
        assert_eq!(
            super::has_avx2(),
            std::arch::is_x86_feature_detected!("avx2")
        );
    }
}
