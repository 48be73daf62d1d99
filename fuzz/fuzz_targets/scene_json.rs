//! libFuzzer target: renderer::fuzz::scene_json (see renderer/src/fuzz.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| renderer::fuzz::scene_json(data));
