//! The `thinshell` command-line tool.
fn main() {
    eprintln!("thinshell: no subcommands yet");
    std::process::exit(2);
}
