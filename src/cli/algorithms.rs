//! `sism algorithms`: the registry, for people (a list) or for the README (`--markdown`).

use sism::algorithms::{Family, REGISTRY};

use super::print_stdout;

#[derive(clap::Args)]
pub struct Args {
    /// Print the README's Markdown table instead of the list.
    #[arg(long)]
    markdown: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.markdown {
        return print_stdout(sism::algorithms::markdown_table().trim_end());
    }
    let mut s = String::new();
    for algo in REGISTRY.iter().filter(|a| a.family != Family::Test) {
        s += &format!(
            "{} ({}{})\n    {}\n",
            algo.name,
            algo.family.name(),
            if algo.kernels { ", --machine" } else { "" },
            algo.summary
        );
        for p in algo.params {
            s += &format!(
                "    --param {}=<{}>  default {}: {}\n",
                p.key,
                p.range(),
                p.default,
                p.description
            );
        }
    }
    print_stdout(s.trim_end())
}
