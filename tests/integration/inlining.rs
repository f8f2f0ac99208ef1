//! Every vector operation of every kernel is compiled inline. A vector operation inside a closure
//! (`|x| s.add_f(..)`, `array::map`, `bool::then`) is compiled without the kernel's target features:
//! the AVX-512 (or AVX2) intrinsics it calls then stay out of line, one call per instruction. It happened
//! once (`sism-sampled`'s light points ran 7× slower on AVX-512 and no image changed), so the
//! `sism` binary's symbol table is checked for intrinsics compiled as functions of their own.

#[test]
fn no_vector_intrinsic_is_compiled_out_of_line() {
    let bin = env!("CARGO_BIN_EXE_sism");
    let out = match std::process::Command::new("nm").args(["-C", bin]).output() {
        Ok(o) if o.status.success() => o,
        _ if std::env::var("CI").is_ok_and(|v| v == "true") => {
            panic!("CI=true but `nm` (binutils) cannot read {bin}")
        }
        _ => {
            eprintln!("skipped: `nm` (binutils) not available");
            return;
        }
    };
    let symbols = String::from_utf8_lossy(&out.stdout);
    let out_of_line: Vec<&str> = symbols
        .lines()
        // AVX-512, AVX2, AVX, FMA and BMI intrinsics (the AVX-512 and AVX2 backends); `xgetbv`
        // is the feature detection's own, called once.
        .filter(|l| l.contains("core_arch::x86") && !l.contains("xsave"))
        .collect();
    assert!(
        out_of_line.is_empty(),
        "vector intrinsics compiled as functions (a vector operation inside a closure?):\n{}",
        out_of_line.join("\n")
    );
}
