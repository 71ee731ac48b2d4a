//! What the struct's attributes mean for the other items the macro emits.
//!
//! The user's attributes go on the struct only, but some of them decide
//! things about the whole system:
//!
//! * `#[cfg(…)]` (also inside `#[cfg_attr(…)]`) decides whether the struct
//!   exists: the evaluation module and the trait impl get the same
//!   conditions, so that a configured-out system leaves nothing behind that
//!   names its type.
//! * `#[derive(…)]`, also inside `#[cfg_attr(…)]`, derives traits the
//!   macro would otherwise derive itself (`struct_item`).
//! * `#[deprecated]` makes every use of the type warn, including the trait
//!   impl's: that impl allows `deprecated`.
//!
//! `#[cfg_attr(P, a, b)]` is read as `a` and `b` under the condition P,
//! nested ones as the conjunction of their conditions. A `cfg_attr` that
//! does not parse is rustc's to report on the struct, and ignored here.

use proc_macro2::{TokenStream, TokenTree};
use quote::{quote, ToTokens};
use syn::parse::{ParseStream, Parser};
use syn::{Attribute, Meta, Token};

/// One attribute as it applies to the struct: its meta (`derive(Clone)`,
/// `cfg(unix)`, …) and the `cfg_attr` predicates that must all hold.
pub struct Effective {
    /// The predicates of the enclosing `cfg_attr`s, outermost first (none for
    /// an attribute written directly).
    pub conditions: Vec<TokenStream>,
    /// The attribute itself.
    pub meta: Meta,
}

impl Effective {
    /// Whether this attribute is `name(…)`, `name = …` or `name`.
    pub fn is(&self, name: &str) -> bool {
        self.meta.path().is_ident(name)
    }

    /// The conjunction of the conditions, `None` if there is none.
    pub fn condition(&self) -> Option<TokenStream> {
        all(&self.conditions)
    }

    /// `#[meta]`, or `#[cfg_attr(condition, meta)]` under a condition.
    pub fn to_attribute(&self) -> TokenStream {
        conditional(self.condition(), self.meta.to_token_stream())
    }
}

/// Every attribute of `attrs`, with `cfg_attr`s flattened.
pub fn effective(attrs: &[Attribute]) -> Vec<Effective> {
    let mut out = Vec::new();
    for attr in attrs {
        flatten(&attr.meta, &mut Vec::new(), &mut out);
    }
    out
}

fn flatten(meta: &Meta, conditions: &mut Vec<TokenStream>, out: &mut Vec<Effective>) {
    let Meta::List(list) = meta else {
        out.push(Effective {
            conditions: conditions.clone(),
            meta: meta.clone(),
        });
        return;
    };
    if !list.path.is_ident("cfg_attr") {
        out.push(Effective {
            conditions: conditions.clone(),
            meta: meta.clone(),
        });
        return;
    }
    let Ok((predicate, metas)) = cfg_attr_args.parse2(list.tokens.clone()) else {
        return;
    };
    conditions.push(predicate.to_token_stream());
    for meta in &metas {
        flatten(meta, conditions, out);
    }
    conditions.pop();
}

/// `predicate, attr, attr, …`: the attributes that do not parse as a
/// `syn::Meta` are left out.
fn cfg_attr_args(input: ParseStream) -> syn::Result<(Meta, Vec<Meta>)> {
    let predicate: Meta = input.parse()?;
    input.parse::<Token![,]>()?;
    let rest: TokenStream = input.parse()?;
    let mut metas = Vec::new();
    let mut current = TokenStream::new();
    for token in rest {
        match &token {
            TokenTree::Punct(p) if p.as_char() == ',' => {
                metas.extend(syn::parse2::<Meta>(std::mem::take(&mut current)).ok());
            }
            _ => current.extend([token]),
        }
    }
    metas.extend(syn::parse2::<Meta>(current).ok());
    Ok((predicate, metas))
}

/// `all(a, b)` for several conditions, `a` for one, `None` for none.
pub fn all(conditions: &[TokenStream]) -> Option<TokenStream> {
    match conditions {
        [] => None,
        [one] => Some(one.clone()),
        many => Some(quote!(all(#(#many),*))),
    }
}

/// `#[body]`, or `#[cfg_attr(condition, body)]`.
pub fn conditional(condition: Option<TokenStream>, body: TokenStream) -> TokenStream {
    match condition {
        None => quote!(#[#body]),
        Some(condition) => quote!(#[cfg_attr(#condition, #body)]),
    }
}

/// The `#[cfg(…)]` attributes of the struct, to put on every other item the
/// macro emits for it (`#[cfg_attr(P, cfg(…))]` for a conditional one).
pub fn cfgs(attrs: &[Attribute]) -> Vec<TokenStream> {
    effective(attrs)
        .iter()
        .filter(|a| a.is("cfg"))
        .map(Effective::to_attribute)
        .collect()
}

/// `#[allow(deprecated)]` for items that name the type, if the struct is
/// `#[deprecated]` (under the same conditions); nothing otherwise, so that
/// a crate that forbids `deprecated` can still use the macro.
pub fn allow_deprecated(attrs: &[Attribute]) -> TokenStream {
    effective(attrs)
        .iter()
        .filter(|a| a.is("deprecated"))
        .map(|a| conditional(a.condition(), quote!(allow(deprecated))))
        .collect()
}

/// The attributes every item other than the struct gets: its `cfg`s, and
/// `allow(deprecated)` if it is deprecated and the item names it.
pub fn outer(attrs: &[Attribute], names_the_type: bool) -> TokenStream {
    let cfgs = cfgs(attrs);
    let deprecated = if names_the_type {
        allow_deprecated(attrs)
    } else {
        TokenStream::new()
    };
    quote!(#(#cfgs)* #deprecated)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attrs(tokens: TokenStream) -> Vec<Attribute> {
        Attribute::parse_outer.parse2(tokens).expect("attributes")
    }

    fn text(tokens: impl IntoIterator<Item = TokenStream>) -> Vec<String> {
        tokens.into_iter().map(|t| t.to_string()).collect()
    }

    #[test]
    fn cfgs_are_found_also_inside_cfg_attr() {
        let attrs = attrs(quote! {
            /// Docs.
            #[cfg(feature = "a")]
            #[cfg_attr(unix, derive(Clone), cfg(test))]
            #[cfg_attr(unix, cfg_attr(windows, cfg(any())))]
            #[cfg_attr(unix, derive(Debug))]
            #[cfg_attr(unix cfg(test))]
        });
        assert_eq!(
            text(cfgs(&attrs)),
            [
                quote!(#[cfg(feature = "a")]).to_string(),
                quote!(#[cfg_attr(unix, cfg(test))]).to_string(),
                quote!(#[cfg_attr(all(unix, windows), cfg(any()))]).to_string(),
            ]
        );
    }

    #[test]
    fn deprecation_is_allowed_only_where_declared() {
        assert!(allow_deprecated(&attrs(quote!(#[derive(Clone)]))).is_empty());
        assert_eq!(
            allow_deprecated(&attrs(quote!(#[deprecated(note = "old")]))).to_string(),
            quote!(#[allow(deprecated)]).to_string()
        );
        assert_eq!(
            allow_deprecated(&attrs(quote!(#[cfg_attr(unix, deprecated)]))).to_string(),
            quote!(#[cfg_attr(unix, allow(deprecated))]).to_string()
        );
    }
}
