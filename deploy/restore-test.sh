#!/bin/sh
# Prove a backup restores: back up DEPOT_DATABASE_URL + DEPOT_DATA_DIR, restore into a fresh
# database (DEPOT_RESTORE_TEST_DB, default depot_restore_check, on the same server) and a
# fresh folder, and compare every table's rows and every image. Exit 0 only when all agree.
#   DEPOT_DATABASE_URL=postgresql+psycopg://postgres@127.0.0.1:5432/depot DEPOT_DATA_DIR=./var deploy/restore-test.sh
set -eu
here=$(cd "$(dirname "$0")" && pwd)
src=${DEPOT_DATABASE_URL:?set DEPOT_DATABASE_URL (the database to check)}
src_data=${DEPOT_DATA_DIR:?set DEPOT_DATA_DIR}
target_db=${DEPOT_RESTORE_TEST_DB:-depot_restore_check}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
libpq=$(printf '%s' "$src" | sed 's/^postgresql+[a-z0-9]*:/postgresql:/')
server=${libpq%/*}
dst="$server/$target_db"
src_db=${libpq##*/}
src_db=${src_db%%\?*}
if [ "$src_db" = "$target_db" ]; then
    echo "depot: DEPOT_RESTORE_TEST_DB ($target_db) is the database being checked; the test drops" \
        "and recreates its target, so name another database (default depot_restore_check)" >&2
    exit 2
fi

psql -q -v ON_ERROR_STOP=1 "$server/postgres" -c "DROP DATABASE IF EXISTS \"$target_db\"" \
    -c "CREATE DATABASE \"$target_db\""
backup=$("$here/backup.sh" "$work/backups")
DEPOT_DATABASE_URL=$dst DEPOT_DATA_DIR="$work/restored" "$here/restore.sh" "$backup" >/dev/null

# Every table's rows, in a stable order, as one checksum per table.
tables_sql="SELECT tablename FROM pg_tables WHERE schemaname = 'public' ORDER BY 1"
fingerprint() {
    for t in $(psql -At "$1" -c "$tables_sql"); do
        printf '%s %s\n' "$t" "$(psql -At "$1" -c "SELECT count(*) || ' ' || md5(coalesce(string_agg(r::text, '|' ORDER BY r::text), '')) FROM \"$t\" r")"
    done
}
fingerprint "$libpq" > "$work/source.txt"
fingerprint "$dst" > "$work/restored.txt"
if ! diff -u "$work/source.txt" "$work/restored.txt"; then
    echo "depot: the restored database differs from the source (diff above)" >&2; exit 1
fi
(cd "$src_data" && find images -type f -exec sha256sum {} + | sort) > "$work/images-source.txt"
(cd "$work/restored" && find images -type f -exec sha256sum {} + | sort) > "$work/images-restored.txt"
if ! diff -u "$work/images-source.txt" "$work/images-restored.txt"; then
    echo "depot: the restored image store differs from the source (diff above)" >&2; exit 1
fi
rows=$(awk '{ n += $2 } END { print n + 0 }' "$work/source.txt")
if [ ! -s "$work/source.txt" ]; then
    echo "depot: the source database has no tables; nothing was verified (is it migrated?)" >&2
    exit 1
fi
echo "restore verified: $(wc -l < "$work/source.txt") tables, $rows rows, $(wc -l < "$work/images-source.txt") images into $target_db"
psql -q "$server/postgres" -c "DROP DATABASE IF EXISTS \"$target_db\""
