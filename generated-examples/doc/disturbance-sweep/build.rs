//! Writes `specs/dN.toml`: the shipped `specs/paper-offset-free.toml` with `[kalman] disturbance`
//! replaced, one file per value swept.

fn main() {
    let shipped = "../../../specs/paper-offset-free.toml";
    println!("cargo:rerun-if-changed={shipped}");
    let text = std::fs::read_to_string(shipped).expect("the shipped spec");
    std::fs::create_dir_all("specs").expect("specs/");
    for (name, value) in [
        ("d0_0025", "0.0025"),
        ("d0_005", "0.005"),
        ("d0_01", "0.01"),
        ("d0_02", "0.02"),
        ("d0_04", "0.04"),
    ] {
        let mut found = false;
        let spec: String = text
            .lines()
            .map(|l| {
                if l.trim_start().starts_with("disturbance") {
                    found = true;
                    format!("disturbance = {value}")
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        assert!(found, "no `disturbance` line in {shipped}");
        let path = format!("specs/{name}.toml");
        if std::fs::read_to_string(&path).ok().as_deref() != Some(spec.as_str()) {
            std::fs::write(&path, spec).expect("write the variant");
        }
    }
}
