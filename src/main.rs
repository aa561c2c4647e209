//! The `murk` command: a thin shell over the library.

#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod cli;

fn main() {
    std::process::exit(cli::run());
}
