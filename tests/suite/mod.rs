mod common;

mod cli_errors;
mod determinism;
mod noise;
mod noise_free;
mod output_noise;
mod terrain_metric;
mod thesis_table3;
