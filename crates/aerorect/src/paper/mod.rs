//! The paper's method and its experiments, as published: rectification of an oblique frame
//! from its six angles to the nadir standard image ([`rectify`]), simulation ([`simulate`]),
//! check-point evaluation ([`evaluate`]), the baselines (GCP polynomials [`gcp`], registration
//! [`register`]), Table 1 ([`compare`]), the attitude-error sensitivity ([`sensitivity`]), the
//! lens models compared ([`lens_compare`]) and the [`demo`] that runs them on bundled data.

pub mod compare;
pub mod demo;
pub mod evaluate;
pub mod gcp;
pub mod lens_compare;
pub mod rectify;
pub mod register;
pub mod sensitivity;
pub mod simulate;
