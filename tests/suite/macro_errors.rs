//! Every class of invalid `metriplectic!` input is a compile error that points
//! at the offending tokens and says what to write instead. The expected
//! messages are the reviewed `tests/ui/*.stderr` snapshots
//! (`TRYBUILD=overwrite cargo test --test suite macro_errors` regenerates
//! them). `tests/ui/pass/` holds declarations that must compile and run.

#[test]
fn invalid_systems_are_compile_errors() {
    let cases = trybuild::TestCases::new();
    cases.compile_fail("tests/ui/*.rs");
    // Valid declarations of the optional sections (regions, the classical
    // form) must compile against the runtime's types and run: in the same
    // batch, so that trybuild builds its test crate once.
    cases.pass("tests/ui/pass/*.rs");
}
