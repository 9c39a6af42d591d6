//! Real spherical harmonics of degree 4 (bands 0–3, 16 coefficients) to encode view directions.

use crate::real::Real;

/// Number of coefficients of the encoding.
pub const SH_DIM: usize = 16;

/// Writes the 16 real SH basis values of the unit direction `d` into `out`.
pub fn sh4<T: Real>(d: [T; 3], out: &mut [T]) {
    let c = |v: f64| T::from_f64(v);
    let [x, y, z] = d;
    let (xx, yy, zz) = (x * x, y * y, z * z);
    out[0] = c(0.282_094_791_773_878_14);
    out[1] = c(-0.488_602_511_902_919_9) * y;
    out[2] = c(0.488_602_511_902_919_9) * z;
    out[3] = c(-0.488_602_511_902_919_9) * x;
    out[4] = c(1.092_548_430_592_079_2) * x * y;
    out[5] = c(-1.092_548_430_592_079_2) * y * z;
    out[6] = c(0.946_174_695_757_56) * zz - c(0.315_391_565_252_52);
    out[7] = c(-1.092_548_430_592_079_2) * x * z;
    out[8] = c(0.546_274_215_296_039_6) * (xx - yy);
    out[9] = c(0.590_043_589_926_643_5) * y * (yy - c(3.0) * xx);
    out[10] = c(2.890_611_442_640_554) * x * y * z;
    out[11] = c(0.457_045_799_464_465_7) * y * (T::ONE - c(5.0) * zz);
    out[12] = c(0.373_176_332_590_115_4) * z * (c(5.0) * zz - c(3.0));
    out[13] = c(0.457_045_799_464_465_7) * x * (T::ONE - c(5.0) * zz);
    out[14] = c(1.445_305_721_320_277) * z * (xx - yy);
    out[15] = c(0.590_043_589_926_643_5) * x * (c(3.0) * yy - xx);
}
