//! Bounds on the whole input, checked before anything recursive sees it.

use proc_macro2::{Delimiter, TokenStream, TokenTree};

use super::expr::MAX_NESTING;

/// Deepest nesting of delimited groups anywhere in the input: the deepest
/// valid input is an expression at [`MAX_NESTING`] inside a reference metric
/// (`reference { metric = [[…]]; }`, three more levels).
const MAX_INPUT_NESTING: usize = MAX_NESTING + 8;
/// Largest number of tokens inside one attribute's brackets: ample for doc
/// comments, `derive`, `allow` and `cfg_attr`, small enough that `syn`'s
/// recursive parsers stay shallow (`#[doc = return return …]` recurses once
/// per token, and 1000 levels overflowed a 2 MiB stack in the tests).
const MAX_ATTRIBUTE_TOKENS: usize = 256;

/// Bounds the whole input before `syn` sees it: `syn` builds its token
/// buffer and parses attribute expressions (`#[doc = …]`) by recursion, so
/// deep nesting or a long prefix-operator chain in an attribute would
/// overflow the compiler's stack instead of producing an error. Iterative,
/// so that it is safe on any input itself.
pub fn check_input_bounds(input: &TokenStream) -> syn::Result<()> {
    let mut stack = vec![input.clone().into_iter()];
    while let Some(tokens) = stack.last_mut() {
        let Some(token) = tokens.next() else {
            stack.pop();
            continue;
        };
        if let TokenTree::Group(group) = token {
            if stack.len() > MAX_INPUT_NESTING {
                return Err(syn::Error::new(
                    group.span(),
                    format!(
                        "brackets nested more than {MAX_INPUT_NESTING} deep; simplify the input"
                    ),
                ));
            }
            stack.push(group.stream().into_iter());
        }
    }
    // Attributes: `#` then a bracketed group, at the top level.
    let top: Vec<TokenTree> = input.clone().into_iter().collect();
    for pair in top.windows(2) {
        if let [TokenTree::Punct(hash), TokenTree::Group(group)] = pair {
            if hash.as_char() == '#' && group.delimiter() == Delimiter::Bracket {
                let count = count_tokens(&group.stream());
                if count > MAX_ATTRIBUTE_TOKENS {
                    return Err(syn::Error::new(
                        group.span(),
                        format!(
                            "attribute too long ({count} tokens, at most {MAX_ATTRIBUTE_TOKENS}); shorten it"
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Number of token trees in a stream, groups included, counted iteratively.
fn count_tokens(stream: &TokenStream) -> usize {
    let mut count = 0;
    let mut stack = vec![stream.clone().into_iter()];
    while let Some(tokens) = stack.last_mut() {
        match tokens.next() {
            None => {
                stack.pop();
            }
            Some(TokenTree::Group(group)) => {
                count += 1;
                stack.push(group.stream().into_iter());
            }
            Some(_) => count += 1,
        }
    }
    count
}
