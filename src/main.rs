//! The `rdr` command line: the entry point; the subcommands are in [`cli`].

use rdr::limits::sanitize;
use std::io::Write;
use std::process::ExitCode;

/// Large blocks on huge pages (`rdr::HugePageAllocator`: fewer page faults when a big
/// mesh is read and its BVH built).
#[global_allocator]
static ALLOCATOR: rdr::HugePageAllocator = rdr::HugePageAllocator;

/// A line on standard error; a full or closed stderr is not an error of ours.
macro_rules! note {
    ($($t:tt)*) => {{
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

mod cli;

fn main() -> ExitCode {
    // a bug must still end as one `error:` line and exit status 1, not a trace per thread
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        note!(
            "error: internal error (a bug in rdr, please report it): {}{at}",
            sanitize(&msg).replace('\n', " ")
        );
        std::process::exit(1);
    }));
    let cli = match <cli::Cli as clap::Parser>::try_parse() {
        Ok(cli) => cli,
        Err(e) => return parse_error(e),
    };
    if let Some(m) = cli.max_memory {
        rdr::limits::set_memory_budget(m);
    }
    let result = cli::run(cli.command);
    match result {
        Ok(code) => code,
        Err(e) if e.is::<cli::common::BrokenPipe>() => ExitCode::SUCCESS,
        Err(e) => {
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            note!("error: {}", sanitize(&msg.join(": ")));
            ExitCode::from(1)
        }
    }
}

/// Command-line errors as every other failure: one `error:` line, exit status 1
/// (`--help` and `--version` print as usual and succeed).
fn parse_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            ExitCode::SUCCESS
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand | ErrorKind::MissingSubcommand => {
            let cmd = <cli::Cli as clap::CommandFactory>::command();
            let names: Vec<&str> = cmd.get_subcommands().map(|c| c.get_name()).filter(|n| *n != "help").collect();
            let list = match names.split_last() {
                Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
                _ => names.join(""),
            };
            note!("error: a subcommand is needed: {list} (see rdr --help)");
            ExitCode::from(1)
        }
        _ => {
            let text = e.render().to_string();
            let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("error: invalid command line");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            // clap's suggestion ("tip: a similar argument exists: '--spp'") is on a later line
            let tip = text
                .lines()
                .filter_map(|l| l.trim().strip_prefix("tip: "))
                .map(|t| match t.split_once(" exists: ") {
                    Some((_, names)) if t.starts_with("a similar") => format!("; did you mean {names}?"),
                    _ => format!("; {t}"),
                })
                .collect::<String>();
            note!("error: {}{} (see rdr --help)", sanitize(first), sanitize(&tip));
            ExitCode::from(1)
        }
    }
}
