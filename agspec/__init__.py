"""agspec: executable specification and conformance toolkit for AssemblyGrid v1."""

__version__ = "0.1.0"
SPEC_VERSION = "assemblygrid-v1/agspec-spec-1"
IR_VERSION = "agspec-ir/1"
