//! Backend selection: environment variable, programmatic override, and
//! run_native following the selection. Single test so the global override
//! cannot race with other tests.

use sism_simd::{
    available, best_available, parse_backend, run_native, selected_backend, set_backend, BackendKind, Kernel,
    Simd,
};

struct Which;
impl Kernel for Which {
    type Output = BackendKind;
    #[inline(always)]
    fn run<S: Simd>(self, s: S) -> BackendKind {
        s.kind()
    }
}

#[test]
fn selection() {
    assert_eq!(parse_backend("auto"), Some(None));
    assert_eq!(parse_backend("AVX512"), Some(Some(BackendKind::Avx512)));
    assert_eq!(parse_backend("avx2"), Some(Some(BackendKind::Avx2)));
    assert_eq!(
        parse_backend("portable-baseline"),
        Some(Some(BackendKind::Portable))
    );
    assert!(matches!(
        parse_backend("portable"),
        Some(Some(BackendKind::Portable | BackendKind::PortableAvx2))
    ));
    assert_eq!(parse_backend("bogus"), None);

    let env = std::env::var("SISM_SIMD").ok();
    let sel = selected_backend();
    println!(
        "SISM_SIMD={env:?} → {sel:?} (best available {:?})",
        best_available()
    );
    match env.as_deref() {
        Some("portable") => assert_ne!(sel, BackendKind::Avx512),
        Some("portable-baseline") => assert_eq!(sel, BackendKind::Portable),
        None | Some("auto") => assert_eq!(sel, best_available()),
        _ => {}
    }
    // The kernel sees the portable backend in both portable variants.
    let k = run_native(Which);
    assert_eq!(
        k,
        match sel {
            BackendKind::Avx512 | BackendKind::Avx2 => sel,
            _ => BackendKind::Portable,
        }
    );

    set_backend(Some(BackendKind::Portable));
    assert_eq!(selected_backend(), BackendKind::Portable);
    assert_eq!(run_native(Which), BackendKind::Portable);
    if available(BackendKind::Avx512) {
        set_backend(Some(BackendKind::Avx512));
        assert_eq!(run_native(Which), BackendKind::Avx512);
    } else {
        println!("note: AVX-512 not detected; skipping forced-AVX-512 check");
    }
    if available(BackendKind::Avx2) {
        set_backend(Some(BackendKind::Avx2));
        assert_eq!(run_native(Which), BackendKind::Avx2);
    }
    set_backend(None);
    assert_eq!(selected_backend(), sel);
}
