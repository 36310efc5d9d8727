mod analytic;
mod bad_maps;
mod image_read;
mod render_adaptive;
mod render_cli;
mod render_fitted;
mod render_table;
mod render_table_adaptive;
