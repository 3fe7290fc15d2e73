//! The manual's command-line reference (`docs/src/reference/cli.md`) is generated from
//! the built binary's `--help`, so it cannot drift from clap's definitions: this test
//! renders it again and compares. `RDR_BLESS=1 cargo test --release --test doc_cli`
//! rewrites the page after a change to the command line.

mod docs_common;

use std::process::Command;

const PAGE: &str = "docs/src/reference/cli.md";

fn help(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(args)
        .arg("--help")
        .output()
        .expect("run rdr --help");
    assert!(
        out.status.success(),
        "rdr {args:?} --help failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).expect("help is UTF-8");
    // trailing spaces (clap pads blank lines of long help) would not survive editors
    let lines: Vec<&str> = text.lines().map(str::trim_end).collect();
    lines.join("\n").trim_end().to_string()
}

/// The subcommands `rdr --help` lists under `Commands:` (without `help`).
fn subcommands(top: &str) -> Vec<String> {
    top.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

fn render_page() -> String {
    let top = help(&[]);
    let commands = subcommands(&top);
    assert!(commands.len() >= 4, "too few subcommands found in `rdr --help`: {commands:?}");
    let mut page = String::from(
        "# Command line\n\n\
         <!-- Generated from `rdr --help` by tests/doc_cli.rs; do not edit. After changing the command line run\n     \
         RDR_BLESS=1 cargo test --release --test doc_cli -->\n\n\
         This page is the built binary's own help, one section per subcommand. \
         `rdr help COMMAND` or `rdr COMMAND --help` print the same; `-h` prints a shorter summary.\n\n\
         ## rdr\n\n```text\n",
    );
    page.push_str(&top);
    page.push_str("\n```\n");
    for c in &commands {
        page.push_str(&format!("\n## rdr {c}\n\n```text\n{}\n```\n", help(&[c])));
    }
    page
}

#[test]
fn cli_reference_matches_the_binary() {
    docs_common::check_generated_page(PAGE, &render_page(), "`rdr --help`", "doc_cli");
}
