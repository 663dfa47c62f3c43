pub fn line(_: &crate::sweep::Row) -> String {
    String::from("row\n")
}
