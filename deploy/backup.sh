#!/bin/sh
# Back up depot: the PostgreSQL database (pg_dump, custom format) and the image store.
#   DEPOT_DATABASE_URL=postgresql+psycopg://user:pw@host/db DEPOT_DATA_DIR=/data deploy/backup.sh OUT_DIR
# Writes OUT_DIR/depot-<UTC time>/ with database.dump, images.tar, SHA256SUMS and prints it.
# The database is dumped first, then the images: an image is written before the event that
# points at it, so every event in the dump finds its image in the (later) image archive.
set -eu
# The dump holds every token and key hash: owner only (files 0600, new folders 0700).
umask 077
out=${1:?usage: deploy/backup.sh OUT_DIR}
url=${DEPOT_DATABASE_URL:?set DEPOT_DATABASE_URL (the database to back up)}
data=${DEPOT_DATA_DIR:?set DEPOT_DATA_DIR (its images/ folder is the image store)}
case $url in postgresql*) ;; *) echo "depot: backup.sh backs up PostgreSQL only; for SQLite copy DEPOT_DATA_DIR while depot is stopped" >&2; exit 2 ;; esac
libpq=$(printf '%s' "$url" | sed 's/^postgresql+[a-z0-9]*:/postgresql:/')
dir="$out/depot-$(date -u +%Y%m%dT%H%M%SZ)"
mkdir -p "$dir"
chmod 700 "$dir"
pg_dump --format=custom --no-owner --no-privileges --file="$dir/database.dump" "$libpq"
mkdir -p "$data/images"
tar -C "$data" -cf "$dir/images.tar" images
(cd "$dir" && sha256sum database.dump images.tar > SHA256SUMS)
echo "$dir"
