mod cli_rule;
mod docs_sync;
mod reliability;
mod reproduce;
