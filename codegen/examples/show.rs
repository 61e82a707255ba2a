fn main() {
    let src = std::fs::read_to_string(std::env::args().nth(1).unwrap()).unwrap();
    match codegen::generate_from_source(&src, &codegen::Opt::default()) {
        Ok(g) => print!("{}", g.pretty()),
        Err(d) => eprintln!("{}", codegen::render::render(&d, &src, "spec")),
    }
}
