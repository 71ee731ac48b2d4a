//! What the data determine about an identified model: which coefficient
//! combinations they fix ([`identifiability`]), how much the coefficients
//! vary over resampled trajectories ([`bootstrap`]), which entropy terms
//! they need ([`sparsify`]) and which degrees ([`select_degrees`]).

mod bootstrap;
mod degrees;
pub(crate) mod identifiability;
mod refit;
mod sparse;

pub use bootstrap::{bootstrap, Bootstrap, BootstrapOptions, Interval};
pub use degrees::{select_degrees, DegreeCandidate, DegreeOptions, DegreeSelection};
pub use identifiability::{
    identifiability, FlatDirection, FlatKind, Identifiability, IdentifiabilityOptions,
};
pub use sparse::{sparsify, SparseCandidate, SparseOptions, Sparsification};
