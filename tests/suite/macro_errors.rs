//! Every class of invalid `metriplectic!` input is a compile error that points
//! at the offending tokens and says what to write instead. The expected
//! messages are the reviewed `tests/ui/*.stderr` snapshots
//! (`TRYBUILD=overwrite cargo test --test suite macro_errors` regenerates
//! them).

#[test]
fn invalid_systems_are_compile_errors() {
    let cases = trybuild::TestCases::new();
    cases.compile_fail("tests/ui/*.rs");
}
