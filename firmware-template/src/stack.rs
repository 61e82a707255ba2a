//! Stack use, measured by painting: the board's startup code fills its main stack with
//! `board::STACK_PAINT`, and a word that no longer holds it has been used.
//!
//! Two figures: the whole run's high-water mark (`high_water`), and the deepest a single control
//! cycle went below the stack pointer of its caller (`CycleProbe`). For the second, the words
//! below the stack pointer are painted again right before each timed `Controller::step` and
//! scanned right after it. Painting and scanning are assembly that uses no stack of its own
//! (Rust code here would put its frame in the very words it paints), and no interrupt is enabled,
//! so nothing else writes below the stack pointer in between.

use crate::board;

/// The most bytes below the stack pointer the probe paints (the first cycle, down to the stack's
/// bottom at most; later cycles paint twice the deepest use seen so far, plus a margin: cycles
/// repeat the same code). The interior-point method keeps its normal matrix on the stack.
const PROBE_MAX: usize = 192 * 1024;
const PROBE_MARGIN: usize = 1024;

/// Bytes of the main stack used so far at most: the painted words that were overwritten, from
/// the bottom up. (A word written with the paint value itself counts as unused.)
pub fn high_water() -> usize {
    let (bottom, top) = board::stack_bounds();
    let mut p = bottom;
    // SAFETY: [bottom, top) is the main stack (the board's linker script reserves it); reading
    // its words, above or below the stack pointer, has no side effect.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == board::STACK_PAINT {
        p += 4;
    }
    top - p
}

/// Deepest stack use of a control cycle.
pub struct CycleProbe {
    /// Bytes painted below the stack pointer before the next cycle.
    window: usize,
    /// Most bytes below the caller's stack pointer any cycle used.
    pub deepest: usize,
    /// Most bytes of the whole stack in use during any cycle: from the top to the deepest word.
    pub from_top: usize,
    /// A cycle used the whole window: `deepest` is then only a lower bound.
    pub overflowed: bool,
}

impl CycleProbe {
    /// No cycle probed yet.
    pub const fn new() -> Self {
        Self {
            window: PROBE_MAX,
            deepest: 0,
            from_top: 0,
            overflowed: false,
        }
    }

    /// Paints the window below the current stack pointer; returns the stack pointer and window
    /// for [`CycleProbe::measure`]. Call it in the function that makes the measured call.
    #[inline(always)]
    pub fn paint(&self) -> (usize, usize) {
        let (bottom, _) = board::stack_bounds();
        let sp: usize;
        // SAFETY: reads the stack pointer.
        unsafe { core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack)) };
        let start = sp.saturating_sub(self.window).max(bottom);
        // SAFETY: writes only the words in [start, sp): stack memory (not below the stack's
        // bottom) that is free (below the stack pointer of this very function, whose frame is
        // above it; no interrupt is enabled), word-aligned (sp is, window is a multiple of 4).
        unsafe {
            core::arch::asm!(
                "2:",
                "cmp {p}, {sp}",
                "bhs 3f",
                "str {paint}, [{p}], #4",
                "b 2b",
                "3:",
                p = inout(reg) start => _,
                sp = in(reg) sp,
                paint = in(reg) board::STACK_PAINT,
                options(nostack),
            );
        }
        (sp, sp - start)
    }

    /// Scans what [`CycleProbe::paint`] painted and records how deep the cycle went.
    #[inline(always)]
    pub fn measure(&mut self, (sp, window): (usize, usize)) {
        let mut p = sp - window;
        // SAFETY: reads only words in [sp - window, sp), which `paint` checked are stack memory.
        unsafe {
            core::arch::asm!(
                "2:",
                "cmp {p}, {sp}",
                "bhs 3f",
                "ldr {t}, [{p}]",
                "cmp {t}, {paint}",
                "bne 3f",
                "add {p}, {p}, #4",
                "b 2b",
                "3:",
                p = inout(reg) p,
                sp = in(reg) sp,
                t = out(reg) _,
                paint = in(reg) board::STACK_PAINT,
                options(nostack, readonly),
            );
        }
        let used = sp - p;
        self.overflowed |= used >= window;
        self.deepest = self.deepest.max(used);
        self.from_top = self.from_top.max(board::stack_bounds().1 - p);
        self.window = (2 * self.deepest + PROBE_MARGIN).min(PROBE_MAX);
    }
}
