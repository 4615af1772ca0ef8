"""The paper's parameters, mirrored once from the Rust `ShieldConfig::default()`."""

from types import MappingProxyType

from shieldnav._core import shield_defaults

#: Keyword arguments of ``Shield(...)`` with the paper's values (read-only).
SHIELD_DEFAULTS = MappingProxyType(shield_defaults())
