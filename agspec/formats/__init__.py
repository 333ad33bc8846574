"""The exchange formats of spec chapter 09, implemented once.

This package is the bottom layer of agspec: it imports nothing from the rest of the package but
``agspec.resources`` and ``agspec.formats.diagnostics``, and everything that reads or writes an exchange
format imports it.

==================  =================================================================================
module              spec
==================  =================================================================================
``actions``         O-ACTION-ENCODING (the 114 action integers) and F-SYMBOLIC-ACTIONS (the symbolic
                    spelling of scripts: ``{"pick": id}``, ``{"support": id}``, ``"deliver"`` ...)
``pointer``         RFC 6901 JSON Pointers (escape, parse, resolve) and ``first_difference``, the one
                    comparison of two JSON values (F-CONFORM step 1, F-DIAGNOSTICS pointers)
``schemas``         the JSON Schemas of ``schemas/`` (one loader, one registry, compiled validators)
                    and the AG2xx wording of a schema violation (F-CODES)
``trace``           F-TRACE: the canonical JSON line, the streaming writer and the streaming reader
``report``          F-REPORT: the conformance report's records, writer and reader
``limits``          F-LIMITS: the bounded reading of every untrusted input (file type and size, UTF-8,
                    JSON and YAML within depth/number/string/alias limits); ``jsonl`` reads through it
==================  =================================================================================
"""
