//! The simulated world: what a sample does at one humidity and temperature (the physics seam,
//! [`physics::Physics`]), how the sample departs from its calibration and what makes a strip
//! itself ([`sample`]), the humidity the chamber holds, the sample follows and the sensor reads
//! ([`bench`]), what the room adds (its temperature, mains pickup: [`surroundings`]), and a strip
//! aged in service ([`aging`]).
//! The recordings' makers measure this world; it reads only the session that sets it up.

pub mod aging;
pub mod bench;
pub mod physics;
pub mod sample;
pub mod surroundings;
