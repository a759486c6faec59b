//! What the sample path does while it waits for the ADC ring's next block, decided once for
//! every board, so that the QEMU board's replay of an overrun runs the hardware board's decisions.
//! - A ring that fell a half-buffer behind restarts at the DMA's position: a gap, flagged.
//! - No block for `ADC_STALL_BLOCKS` periods with the ADC's overrun flag set: the DMA requests
//!   stay blocked until the conversions are stopped, the flag cleared and the conversions
//!   started again (RM0351, "Managing conversions using the DMA"), so the board restarts them
//!   and the gap is flagged as an overrun. Waiting instead leaves the board to the watchdog.
//! - No block without the flag (a hung DMA) is the watchdog's: the board waits on.

use crate::wire::stream::flags;

/// How one wait for a block ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Waited {
    Block,
    /// The sample path fell a whole half-buffer behind the DMA.
    FellBehind,
    /// No block came within the stall limit; `adc_overran`: the ADC's OVR flag was set.
    Silent {
        adc_overran: bool,
    },
}

/// What the board does next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[must_use]
pub enum Then {
    /// Take the block.
    Take,
    /// Stop the conversions, clear the overrun, start them again, then wait for a block.
    RestartConversions,
    WaitAgain,
}

/// The waits for one block: what to do after each, and what the block is flagged with.
#[derive(Clone, Copy, Debug, Default)]
pub struct BlockWait {
    flags: u16,
    gap: bool,
}

impl BlockWait {
    pub const fn new() -> Self {
        BlockWait { flags: 0, gap: false }
    }

    pub fn after(&mut self, waited: Waited) -> Then {
        match waited {
            Waited::Block => Then::Take,
            Waited::FellBehind => {
                self.flags |= flags::SAMPLES_LOST;
                self.gap = true;
                Then::WaitAgain
            }
            Waited::Silent { adc_overran: true } => {
                self.flags |= flags::ADC_OVERRUN | flags::SAMPLES_LOST;
                self.gap = true;
                Then::RestartConversions
            }
            Waited::Silent { adc_overran: false } => Then::WaitAgain,
        }
    }

    /// The flags the block that ends the waits carries.
    pub fn flags(&self) -> u16 {
        self.flags
    }

    /// The ring lost its place before the block (`RingBlocks::block` counts what that cost).
    pub fn gap(&self) -> bool {
        self.gap
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_overrun_restarts_the_conversions_and_is_flagged() {
        let mut w = BlockWait::new();
        assert_eq!(w.after(Waited::Silent { adc_overran: true }), Then::RestartConversions);
        assert_eq!(w.after(Waited::Block), Then::Take);
        assert_eq!(w.flags(), flags::ADC_OVERRUN | flags::SAMPLES_LOST);
        assert!(w.gap());
    }

    #[test]
    fn a_silent_ring_without_an_overrun_is_left_to_the_watchdog() {
        let mut w = BlockWait::new();
        assert_eq!(w.after(Waited::Silent { adc_overran: false }), Then::WaitAgain);
        assert_eq!(w.after(Waited::Block), Then::Take);
        assert_eq!((w.flags(), w.gap()), (0, false));
    }

    #[test]
    fn a_ring_fallen_behind_is_a_gap_not_an_overrun() {
        let mut w = BlockWait::new();
        assert_eq!(w.after(Waited::FellBehind), Then::WaitAgain);
        assert_eq!(w.after(Waited::Block), Then::Take);
        assert_eq!(w.flags(), flags::SAMPLES_LOST);
        assert!(w.gap());
    }
}
