"""Validates volmap's --json files against their JSON Schemas (docs/schema/), as a user's
script would: `validate_json.py SCHEMA.json REPORT.json [REPORT.json ...]`. Prints one line per
report; exits 1 naming each report that does not validate and why."""

import json
import sys

import jsonschema


def main():
    with open(sys.argv[1], encoding="utf-8") as f:
        schema = json.load(f)
    validator = jsonschema.Draft202012Validator(schema)
    jsonschema.Draft202012Validator.check_schema(schema)
    failed = False
    for path in sys.argv[2:]:
        with open(path, encoding="utf-8") as f:
            report = json.load(f)
        errors = sorted(validator.iter_errors(report), key=lambda e: list(e.path))
        if errors:
            failed = True
            for error in errors[:5]:
                where = "/".join(str(p) for p in error.path)
                print(f"{path}: at /{where}: {error.message[:300]}")
        else:
            print(f"{path}: valid")
    sys.exit(1 if failed else 0)


main()
