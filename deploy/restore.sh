#!/bin/sh
# Restore a backup made by deploy/backup.sh into DEPOT_DATABASE_URL and DEPOT_DATA_DIR.
#   DEPOT_DATABASE_URL=... DEPOT_DATA_DIR=/data deploy/restore.sh BACKUP_DIR
# The target database must exist (createdb); what it holds is replaced. Stop depot first.
# Afterwards run `depot migrate`: a backup from an older version is brought to the schema head.
set -eu
dir=${1:?usage: deploy/restore.sh BACKUP_DIR}
url=${DEPOT_DATABASE_URL:?set DEPOT_DATABASE_URL (the database to restore into)}
data=${DEPOT_DATA_DIR:?set DEPOT_DATA_DIR (the image store goes to its images/ folder)}
[ -d "$dir" ] || { echo "depot: $dir is not a backup folder (made by deploy/backup.sh)" >&2; exit 2; }
# Both parts must be listed: a SHA256SUMS without one of them would let a damaged part through.
for part in database.dump images.tar; do
    grep -q "  $part\$" "$dir/SHA256SUMS" 2>/dev/null || {
        echo "depot: $dir/SHA256SUMS does not list $part; the backup is incomplete, take another" >&2
        exit 2; }
done
(cd "$dir" && sha256sum --check --quiet SHA256SUMS) || {
    echo "depot: $dir fails its checksums; the backup is damaged, take another" >&2; exit 2; }
libpq=$(printf '%s' "$url" | sed 's/^postgresql+[a-z0-9]*:/postgresql:/')
pg_restore --clean --if-exists --no-owner --no-privileges --exit-on-error \
    --single-transaction --dbname="$libpq" "$dir/database.dump"
mkdir -p "$data"
tar -C "$data" -xf "$dir/images.tar"
echo "restored $dir"
