//! The documentation's links lead somewhere: in `README.md` and every `docs/*.md`, each inline
//! link `[text](target)` outside fenced code blocks that is not `http(s):` or `mailto:` names a
//! file that exists (relative to the page), each `#anchor` names a heading of its page (GitHub's
//! slugs), and `README.md` links every page under `docs/`. Every broken link is reported at once.

use std::collections::HashSet;
use std::fs;
use std::path::{Path, PathBuf};

/// `README.md` first, then every `docs/*.md`, sorted: each as its name in the workspace and its
/// path.
fn pages() -> Vec<(String, PathBuf)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut names: Vec<String> = fs::read_dir(root.join("docs"))
        .expect("docs/ is readable")
        .map(|entry| entry.expect("a docs/ entry").file_name())
        .filter_map(|name| Some(format!("docs/{}", name.to_str()?)))
        .filter(|name| name.ends_with(".md"))
        .collect();
    names.sort();
    names.insert(0, "README.md".to_owned());
    names
        .into_iter()
        .map(|name| (name.clone(), root.join(name)))
        .collect()
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The lines of `text` outside fenced code blocks.
fn prose(text: &str) -> impl Iterator<Item = &str> {
    let mut in_code = false;
    text.lines().filter(move |line| {
        let fence = ["```", "~~~"]
            .iter()
            .any(|f| line.trim_start().starts_with(f));
        in_code ^= fence;
        !in_code && !fence
    })
}

/// The targets of the inline links (and images) in `text`. Brackets in code spans, which may
/// run over line ends but not past a paragraph, are not links.
fn links(text: &str) -> Vec<String> {
    let lines: Vec<&str> = prose(text).collect();
    let mut targets = Vec::new();
    for paragraph in lines.split(|line| line.trim().is_empty()) {
        let outside_code: String = paragraph.join("\n").split('`').step_by(2).collect();
        let mut rest = outside_code.as_str();
        while let Some(at) = rest.find("](") {
            rest = &rest[at + 2..];
            let Some(end) = rest.find(')') else { break };
            let target = rest[..end].split_whitespace().next().unwrap_or_default();
            targets.push(target.trim_matches(['<', '>']).to_owned());
            rest = &rest[end + 1..];
        }
    }
    targets
}

/// GitHub's anchors for the headings of `text`: lower case, every character but alphanumerics,
/// spaces, `-` and `_` removed, spaces made `-`; a repeated slug gets `-1`, `-2`, ...
fn anchors(text: &str) -> HashSet<String> {
    let mut anchors = HashSet::new();
    for line in prose(text) {
        let level = line.chars().take_while(|&c| c == '#').count();
        let Some(title) = line[level..].strip_prefix(' ') else {
            continue;
        };
        if !(1..=6).contains(&level) {
            continue;
        }
        let slug: String = title
            .trim()
            .trim_end_matches('#')
            .trim()
            .to_lowercase()
            .chars()
            .filter(|&c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let (mut unique, mut n) = (slug.clone(), 0);
        while !anchors.insert(unique.clone()) {
            n += 1;
            unique = format!("{slug}-{n}");
        }
    }
    anchors
}

#[test]
fn links_resolve_and_readme_links_every_page() {
    let mut broken = Vec::new();
    let mut linked_from_readme = HashSet::new();
    for (name, page) in pages() {
        let dir = page.parent().expect("a page has a directory");
        for target in links(&read(&page)) {
            let external = ["http://", "https://", "mailto:"];
            if external.iter().any(|scheme| target.starts_with(scheme)) {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((path, anchor)) => (path, Some(anchor)),
                None => (target.as_str(), None),
            };
            let file = if path.is_empty() {
                page.clone()
            } else {
                dir.join(path)
            };
            let Ok(file) = file.canonicalize() else {
                broken.push(format!("{name}: ({target}): no such file"));
                continue;
            };
            if name == "README.md" {
                linked_from_readme.insert(file.clone());
            }
            let markdown = file.extension().is_some_and(|ext| ext == "md");
            if let Some(anchor) = anchor.filter(|_| markdown) {
                if !anchors(&read(&file)).contains(anchor) {
                    broken.push(format!("{name}: ({target}): no heading with that anchor"));
                }
            }
        }
    }
    for (name, page) in pages().into_iter().skip(1) {
        let page = page.canonicalize().expect("a docs page exists");
        if !linked_from_readme.contains(&page) {
            broken.push(format!("README.md: no link to {name}"));
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}
