mod cli_rule;
mod docs_sync;
mod reproduce;
