//! Every error of one invocation, reported together.
//!
//! The stages push each spanned error here and carry on with what is still
//! checkable (the pattern of serde_derive's `internals::ctxt::Ctxt`), so one
//! compile shows a bad constant, a non-skew Π and an odd metric degree at
//! once instead of one per edit–compile cycle. Parts that depend on a broken
//! part are skipped rather than reported again.

/// An accumulator of spanned errors.
#[derive(Debug, Default)]
pub struct Diagnostics {
    errors: Vec<syn::Error>,
}

impl Diagnostics {
    /// No errors yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records an error.
    pub fn push(&mut self, error: syn::Error) {
        self.errors.push(error);
    }

    /// The value of `result`, or `None` after recording its error.
    pub fn record<T>(&mut self, result: syn::Result<T>) -> Option<T> {
        match result {
            Ok(value) => Some(value),
            Err(error) => {
                self.push(error);
                None
            }
        }
    }

    /// Number of errors so far: comparing counts tells whether a step failed.
    pub fn count(&self) -> usize {
        self.errors.len()
    }

    /// All errors combined into one (`None` without errors), in the order
    /// they were found.
    pub fn into_error(self) -> Option<syn::Error> {
        let mut errors = self.errors.into_iter();
        let mut combined = errors.next()?;
        for error in errors {
            combined.combine(error);
        }
        Some(combined)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proc_macro2::Span;

    #[test]
    fn errors_combine_in_order() {
        let mut diagnostics = Diagnostics::new();
        assert!(diagnostics.record(Ok::<_, syn::Error>(1)).is_some());
        assert_eq!(diagnostics.count(), 0);
        diagnostics.push(syn::Error::new(Span::call_site(), "first"));
        let none: Option<()> =
            diagnostics.record(Err(syn::Error::new(Span::call_site(), "second")));
        assert!(none.is_none());
        let messages: Vec<String> = diagnostics
            .into_error()
            .into_iter()
            .flatten()
            .map(|e| e.to_string())
            .collect();
        assert_eq!(messages, ["first", "second"]);
        assert!(Diagnostics::new().into_error().is_none());
    }
}
