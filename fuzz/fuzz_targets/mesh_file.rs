#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| terzaghi::fuzzing::mesh_file(data));
