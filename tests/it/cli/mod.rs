mod cli_rule;
mod docs_sync;
mod hostile;
mod reliability;
mod reproduce;
