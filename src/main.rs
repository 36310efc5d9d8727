use std::process::ExitCode;

fn main() -> ExitCode {
    match workbench::cli::main() {
        Ok(code) => code,
        // `workbench … | head`: the reader has all it wanted.
        Err(e) if workbench::io::is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            workbench::status!("Error: {e:#}");
            if e.downcast_ref::<workbench::io::InputError>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
