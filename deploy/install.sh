#!/bin/sh
# Install edged as a systemd service on a gateway (run as root from a clone):
#
#   sudo deploy/install.sh
#
# What it does, each step only when needed (running it again upgrades the program and
# changes nothing else):
#   - the system user and group `edged` (in `dialout`, for serial ports);
#   - a virtualenv in /opt/edged/venv with edged installed from this clone;
#   - /etc/edged/edged.toml from deploy/edged.toml, never over an existing one;
#   - /var/lib/edged for the recordings, owned by edged;
#   - /etc/systemd/system/edged.service, then `systemctl daemon-reload`.
# Then check the configuration and start it:
#   /opt/edged/venv/bin/edged check-config /etc/edged/edged.toml
#   systemctl enable --now edged && journalctl -u edged -f
#
# DESTDIR=/some/root installs into a staging tree instead (no user, no systemctl, no
# chown: what a package build or a test does). PYTHON picks the interpreter (3.11+);
# EDGED_PIP=0 leaves the virtualenv's packages as they are.
set -eu

SRC=$(cd "$(dirname "$0")/.." && pwd)
DESTDIR=${DESTDIR:-}
PYTHON=${PYTHON:-python3}
EDGED_PIP=${EDGED_PIP:-1}
PREFIX=/opt/edged
CONF=/etc/edged
STATE=/var/lib/edged
UNIT=/etc/systemd/system/edged.service

say() { printf 'install.sh: %s\n' "$*"; }

if [ -z "$DESTDIR" ] && [ "$(id -u)" != 0 ]; then
    say "run as root (or set DESTDIR to install into a staging tree)" >&2
    exit 2
fi

# The user and group.
if [ -z "$DESTDIR" ]; then
    if ! getent group edged >/dev/null; then
        groupadd --system edged
        say "group edged created"
    fi
    if ! id -u edged >/dev/null 2>&1; then
        useradd --system --gid edged --home-dir "$STATE" --no-create-home \
            --shell /usr/sbin/nologin --comment "edged vessel edge daemon" edged
        say "user edged created"
    fi
    if getent group dialout >/dev/null && ! id -nG edged | tr ' ' '\n' | grep -qx dialout; then
        usermod -a -G dialout edged
        say "user edged added to dialout (serial ports)"
    fi
fi

# The program.
if [ ! -x "$DESTDIR$PREFIX/venv/bin/python" ]; then
    mkdir -p "$DESTDIR$PREFIX"
    "$PYTHON" -m venv "$DESTDIR$PREFIX/venv"
    say "virtualenv $PREFIX/venv created"
fi
if [ "$EDGED_PIP" != 0 ]; then
    "$DESTDIR$PREFIX/venv/bin/python" -m pip install --quiet --upgrade "$SRC"
    say "edged installed from $SRC into $PREFIX/venv"
fi

# The configuration: an example the first time, never over the operator's file.
mkdir -p "$DESTDIR$CONF"
if [ ! -e "$DESTDIR$CONF/edged.toml" ]; then
    install -m 0640 "$SRC/deploy/edged.toml" "$DESTDIR$CONF/edged.toml"
    [ -z "$DESTDIR" ] && chgrp edged "$CONF/edged.toml"
    say "$CONF/edged.toml written from the example: set vessel_id and the inputs"
else
    say "$CONF/edged.toml kept as it is"
fi

# The recordings' folder (systemd's StateDirectory= makes it too, with these owners).
mkdir -p "$DESTDIR$STATE"
chmod 0750 "$DESTDIR$STATE"
[ -z "$DESTDIR" ] && chown edged:edged "$STATE"

# The unit.
mkdir -p "$(dirname "$DESTDIR$UNIT")"
if ! cmp -s "$SRC/deploy/edged.service" "$DESTDIR$UNIT" 2>/dev/null; then
    install -m 0644 "$SRC/deploy/edged.service" "$DESTDIR$UNIT"
    say "$UNIT installed"
    if [ -z "$DESTDIR" ] && [ -d /run/systemd/system ]; then
        systemctl daemon-reload
    fi
fi
say "done: check the configuration with $PREFIX/venv/bin/edged check-config $CONF/edged.toml," \
    "then: systemctl enable --now edged"
