//! The block lengths of the row loops, apart so that the fast positions (`relative`), the
//! shared types and the buffers all take them from below.

/// The most destination pixels handled per block: coordinates, taps and all bands stay in L1
/// (a block's set-up, fast positions' above all, is then paid once per 1024 pixels).
pub(crate) const BLOCK: usize = 1024;

/// The shortest block fast positions are tried on (`RowPlan::block`).
pub(crate) const MIN_FAST_BLOCK: usize = 256;
