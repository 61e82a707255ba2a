//! A value of the wrong shape is reported as that shape's mistake, first: a matrix written as a flat list,
//! a table written as a number.

use mpc_spec::load;

const LINEAR: &str = r#"[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005], [0.1]]
c = [[1, 0]]

[mpc]
horizon = 10
iterations = 40
q = [1, 1]
r = [0.1]
u_min = [-1]
u_max = [1]

[kalman]
q = [[0.0001, 0], [0, 0.01]]
r = [[0.01]]
"#;

/// Every diagnostic's message and the text its span covers, in order.
fn errors(src: &str) -> Vec<(String, String)> {
    load(src)
        .expect_err("the spec should be rejected")
        .iter()
        .map(|d| {
            let at = d.span.clone().map_or(String::new(), |s| src[s].to_string());
            (d.message.clone(), at)
        })
        .collect()
}

#[test]
fn a_flat_matrix_is_not_a_list_of_rows() {
    assert!(load(LINEAR).is_ok());
    let src = LINEAR.replace("a = [[1, 0.1], [0, 1]]", "a = [1, 0.1, 0, 1]");
    let errs = errors(&src);
    assert_eq!(
        errs[0],
        (
            "`model.a` must be a list of rows, found a flat list of 4 entries".to_string(),
            "[1, 0.1, 0, 1]".to_string()
        )
    );
    // A number among rows is that row's mistake, as before.
    let src = LINEAR.replace("a = [[1, 0.1], [0, 1]]", "a = [[1, 0.1], 7]");
    assert!(errors(&src)[0]
        .0
        .starts_with("`model.a` must be a list of numbers"));
    let src = LINEAR.replace("a = [[1, 0.1], [0, 1]]", "a = [[1, \"x\"], [0, 1]]");
    assert!(errors(&src)[0].0.starts_with("`model.a` must be a number"));
}

#[test]
fn a_table_written_as_a_number_is_reported_once_at_its_key() {
    let src = format!("kalman = 3\n{}", LINEAR.split("[kalman]").next().unwrap());
    let errs = errors(&src);
    assert_eq!(
        errs,
        [(
            "`kalman` must be a table, found integer".to_string(),
            "3".to_string()
        )]
    );
    // An empty `[kalman]` is a table without a noise model.
    let empty = format!("{}[kalman]\n", LINEAR.split("[kalman]").next().unwrap());
    assert_eq!(errors(&empty)[0].0, "missing noise model in `[kalman]`");
}
