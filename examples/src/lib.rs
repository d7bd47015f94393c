//! Examples live beside this crate: `cargo run -p relief-examples --example NAME`.
#![deny(missing_docs)]
