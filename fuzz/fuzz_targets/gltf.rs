//! libFuzzer target: renderer::fuzz::gltf (see renderer/src/fuzz.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| renderer::fuzz::gltf(data));
