//! Executable rules about the workspace itself: every member crate is re-exported by
//! the facade, listed in `wavelux::CRATES` and in the README's crate table.

use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn library_members() -> anyhow::Result<Vec<String>> {
    let manifest: toml::Table = std::fs::read_to_string(root().join("Cargo.toml"))?.parse()?;
    let members = manifest["workspace"]["members"]
        .as_array()
        .ok_or_else(|| anyhow::anyhow!("workspace.members is not an array"))?;
    let mut names = Vec::new();
    for m in members {
        let dir = m.as_str().unwrap_or_default();
        if !dir.starts_with("crates/") || dir == "crates/wavelux" {
            continue;
        }
        let pkg: toml::Table =
            std::fs::read_to_string(root().join(dir).join("Cargo.toml"))?.parse()?;
        names.push(
            pkg["package"]["name"]
                .as_str()
                .unwrap_or_default()
                .to_string(),
        );
    }
    Ok(names)
}

#[test]
fn every_library_crate_is_in_the_facade_and_readme() -> anyhow::Result<()> {
    let members = library_members()?;
    assert!(!members.is_empty());
    let readme = std::fs::read_to_string(root().join("README.md"))?;
    let facade = std::fs::read_to_string(root().join("crates/wavelux/src/lib.rs"))?;
    for name in &members {
        assert!(
            wavelux::CRATES.iter().any(|(n, _)| n == name),
            "{name} missing from wavelux::CRATES"
        );
        assert!(
            readme.contains(&format!("`{name}`")),
            "{name} missing from README's crate table"
        );
        let ident = name.replace('-', "_");
        assert!(
            facade.contains(&format!("pub use {ident} as")),
            "{name} not re-exported by the facade"
        );
    }
    assert_eq!(
        wavelux::CRATES.len(),
        members.len(),
        "wavelux::CRATES lists a crate that is not a member"
    );
    Ok(())
}
