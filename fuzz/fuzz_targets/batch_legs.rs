#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| terzaghi::fuzzing::batch_legs(data));
