//! Proof of the diagnosis on cases whose truth is known: sessions made with one concealed effect
//! each and clean controls (`cases`), or recordings made elsewhere with their truths
//! (`external`), each verdict classed against its truth and tabled (`outcome`).

pub mod cases;
pub mod external;
pub mod outcome;
