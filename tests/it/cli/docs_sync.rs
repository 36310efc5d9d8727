//! `docs/math.md` and `docs/render-scene.md` are copies of the team's shared specification
//! (`../shared/docs/`), kept in the repository so that a clone has the formulas its README
//! cites. Where the shared folder sits beside the checkout (as in CI), the copies must match.

use std::path::Path;

#[test]
fn docs_match_the_shared_specification() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let shared = root.join("../shared/docs");
    for name in ["math.md", "render-scene.md"] {
        let ours = std::fs::read_to_string(root.join("docs").join(name)).expect("docs/ copy exists");
        assert!(ours.contains("# "), "docs/{name} is empty");
        match std::fs::read_to_string(shared.join(name)) {
            Ok(theirs) => assert!(
                ours == theirs,
                "docs/{name} differs from ../shared/docs/{name}: copy it again"
            ),
            Err(_) => eprintln!("note: ../shared/docs/{name} not found; docs/{name} not compared"),
        }
    }
}
