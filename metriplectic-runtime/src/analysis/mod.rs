//! What the data determine about an identified model: which coefficient
//! combinations they fix ([`identifiability`]), how much the coefficients
//! vary over resampled trajectories ([`bootstrap`]), which terms they need
//! ([`sparsify`]) and which degrees ([`select_degrees`]).

mod identifiability;

pub use identifiability::{
    identifiability, FlatDirection, FlatKind, Identifiability, IdentifiabilityOptions,
};
