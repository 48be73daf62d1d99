//! libFuzzer target: renderer::fuzz::scn (see renderer/src/fuzz.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| renderer::fuzz::scn(data));
