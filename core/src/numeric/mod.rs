//! Numbers without physics: the scalar type the core is generic over ([`real`]: f32 on the
//! device, f64 on the host, every transcendental through libm so both sides compute the same
//! bits, but f32's sine and cosine, [`sine_f32`], f32 arithmetic only), polynomial roots ([`roots`]), small least squares ([`lstsq`]) and a line fitted with forgetting
//! ([`forgetting_line`]) and the real FFT of the
//! running spectrum ([`fft`]), and the biquad section recursive filters run ([`section`]). Nothing
//! here imports another room.

pub mod fft;
pub mod forgetting_line;
pub mod lstsq;
pub mod real;
pub mod roots;
pub mod section;
pub mod sine_f32;
