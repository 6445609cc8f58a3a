mod common;

mod bias_bounds;
mod cli_errors;
mod determinism;
mod figures;
mod layering;
mod line_fit;
mod mcse;
mod noise;
mod noise_free;
mod output_integrity;
mod output_noise;
mod profiles;
mod routes;
mod shards_resume;
mod terrain_metric;
mod thesis_table3;
