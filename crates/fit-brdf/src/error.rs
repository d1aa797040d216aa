//! Errors of the command line: a cause chain plus the exit class.

use std::fmt::Display;

/// Why a command failed, which decides the exit code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// The user's input (a file, a value) is wrong: exit 2.
    BadInput,
    /// Something failed at run time (a write, a resource): exit 1.
    Runtime,
}

/// A failed command: what went wrong, with its causes.
#[derive(Debug)]
pub struct CliError {
    pub class: Class,
    pub error: anyhow::Error,
}

impl CliError {
    pub fn exit_code(&self) -> i32 {
        match self.class {
            Class::BadInput => 2,
            Class::Runtime => 1,
        }
    }

    /// Prints `error: <what>` and every cause on stderr.
    pub fn report(&self) {
        eprintln!("error: {}", self.error);
        for cause in self.error.chain().skip(1) {
            eprintln!("  caused by: {cause}");
        }
    }
}

/// Wraps an error as bad input (exit 2).
pub fn bad_input(e: impl Into<anyhow::Error>) -> CliError {
    CliError {
        class: Class::BadInput,
        error: e.into(),
    }
}

/// Wraps an error as a runtime failure (exit 1).
pub fn runtime(e: impl Into<anyhow::Error>) -> CliError {
    CliError {
        class: Class::Runtime,
        error: e.into(),
    }
}

/// A bad-input error from a message.
pub fn bad_msg(msg: impl Display) -> CliError {
    bad_input(anyhow::anyhow!("{msg}"))
}

pub type CliResult<T> = Result<T, CliError>;
