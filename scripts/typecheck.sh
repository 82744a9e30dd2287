#!/usr/bin/env bash
# Type-check the installed package `bimbot` with mypy (settings in pyproject.toml, [tool.mypy]).
#
# The repository keeps services/ and shared/ at its top while they install as bimbot.services and
# bimbot.shared (setuptools package-dir). mypy maps files to modules by their folders and does not run the
# editable install's import hook, so it is given the package as it installs: a temporary folder where
# bimbot/ holds links to bimbot/*, services/ and shared/. Every module is then checked under its real name.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
view="$(mktemp -d)"
trap 'rm -rf "$view"' EXIT
mkdir "$view/bimbot"
for entry in "$root"/bimbot/*; do
    ln -s "$entry" "$view/bimbot/"
done
ln -s "$root/services" "$view/bimbot/services"
ln -s "$root/shared" "$view/bimbot/shared"
cd "$view"
MYPYPATH="$view" "$root/.venv/bin/mypy" --config-file "$root/pyproject.toml" --cache-dir "$root/.mypy_cache" -p bimbot
