"""Reading input files: TOML with errors that name the file, and one schema check for every input kind."""

from pkmstiff.io.schema import check_format_version, check_keys, require
from pkmstiff.io.toml import read_toml

__all__ = ["check_format_version", "check_keys", "read_toml", "require"]
