//! What a world generator kind is: the trait a kind implements and the error it returns for a
//! parameter that cannot make a world. The registry and the bundled kinds build on these.

/// A parameter that cannot make a world: the parameter's name and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    pub param: String,
    pub msg: String,
}

impl ParamError {
    pub fn new(param: impl Into<String>, msg: impl Into<String>) -> Self {
        Self {
            param: param.into(),
            msg: msg.into(),
        }
    }
}

/// A kind of world generator. Implement it and [`GeneratorRegistry::register`] it to make
/// a new kind usable from generator files, scenarios and the CLI.
pub trait WorldGenerator: Send + Sync {
    /// Every parameter this kind takes, with its default value. Keys not listed here are
    /// refused by name before [`WorldGenerator::generate_toml`] is called.
    fn defaults(&self) -> toml::Table;

    /// The explicit world TOML text for `params` (the generator file's keys other than
    /// `generator`, only known ones, missing ones left to their defaults). Deterministic:
    /// the same parameters give the same text.
    fn generate_toml(&self, params: &toml::Table) -> Result<String, ParamError>;
}
