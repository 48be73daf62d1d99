//! libFuzzer target: renderer::fuzz::mitsuba_xml (see renderer/src/fuzz.rs).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| renderer::fuzz::mitsuba_xml(data));
