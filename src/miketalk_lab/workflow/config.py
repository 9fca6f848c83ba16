"""The workflow's config checked against its schema, its defaults filled in, and the helpers
every setting read from it goes through.

The schema (:data:`SCHEMA`, under the repository root) documents every key and its
default. :func:`validate_config` fills the defaults into the config in place, as
Snakemake's own ``validate`` does, and reports a violation in one line naming the key.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import yaml
from jsonschema import Draft202012Validator, ValidationError, validators

#: The config's schema, relative to the repository root.
SCHEMA = Path("workflow/schemas/config.schema.yaml")


class ConfigError(ValueError):
    """A config the workflow refuses, before any job: one line per problem, each naming the
    config key (``config: faces.s1.corpus.train: [] should be non-empty``) or the face
    and the clip."""


def _set_defaults(validator_class: type) -> type:
    """``validator_class`` that fills in each property's default before checking it (the
    jsonschema FAQ's recipe, which Snakemake's ``validate`` uses)."""
    check_properties = validator_class.VALIDATORS["properties"]

    def properties(
        validator: Any, properties: Mapping, instance: Any, schema: Mapping
    ) -> Iterator[ValidationError]:
        for name, subschema in properties.items():
            if "default" in subschema:
                instance.setdefault(name, subschema["default"])
        yield from check_properties(validator, properties, instance, schema)

    return validators.extend(validator_class, {"properties": properties})


_DefaultsValidator = _set_defaults(Draft202012Validator)


def validate_config(config: dict, schema: Path) -> dict:
    """Check ``config`` against ``schema``, filling in the schema's defaults in place.

    Parameters
    ----------
    config : dict
        The config as loaded (Snakemake's ``config``); changed in place.
    schema : Path
        The schema file (YAML), e.g. the repository root / :data:`SCHEMA`.

    Returns
    -------
    dict
        ``config``, its defaults filled in.

    Raises
    ------
    ConfigError
        For the first violation, in one line naming the key (:func:`violation`).
    """
    # loaded for each config: the defaults are put into it as they are, not copied
    loaded = yaml.safe_load(Path(schema).read_text(encoding="utf-8"))
    try:
        _DefaultsValidator(loaded).validate(config)
    except ValidationError as error:
        raise ConfigError(violation(error)) from None
    return config


def violation(error: ValidationError) -> str:
    """One line for a schema violation: ``config: <key>: <what is wrong>``.

    A source video's choice of files and a repeated list item are said in words, instead of
    the schema's dump.

    Parameters
    ----------
    error : jsonschema.ValidationError
        The violation.

    Returns
    -------
    str
        E.g. ``config: faces.s1.corpus.test: bbas3a listed twice``.
    """
    key = ".".join(str(part) for part in error.absolute_path) or "the config"
    message = error.message
    if error.validator == "oneOf" and key.endswith(".corpus"):  # source video's choices
        message = (
            "source video takes video (a recording of the corpus words), or media with "
            "its transcript or its subtitles (one of the two)"
        )
    if error.validator == "uniqueItems":  # name the repeated items
        items = [str(item) for item in error.instance]
        message = f"{', '.join(sorted({i for i in items if items.count(i) > 1}))} listed twice"
    return f"config: {key}: {message}"


def canonical(value: Any) -> Any:
    """``value`` with the keys of every mapping in it sorted (lists keep their order).

    Params are compared as written (their repr), and the schema's defaults are added after
    the keys a config gives: a config with the same settings in another key order would
    otherwise change every dict param and rerun the workflow. Every dict param goes
    through here.

    Parameters
    ----------
    value : Any
        A config value: a mapping, a list or a scalar.

    Returns
    -------
    Any
        The same value, its mappings' keys in sorted order.
    """
    if isinstance(value, dict):
        return {key: canonical(value[key]) for key in sorted(value)}
    if isinstance(value, list):
        return [canonical(item) for item in value]
    return value


def project_path(path: str | Path | None, root: Path) -> str | None:
    """A path from the config: relative ones are relative to the project directory.

    Parameters
    ----------
    path : str or Path or None
        As the config gives it (None: not given).
    root : Path
        The project directory (where the Snakefile is).

    Returns
    -------
    str or None
        The path, absolute; None for None.
    """
    if path is None:
        return None
    return str(path) if Path(path).is_absolute() else str(root / path)
