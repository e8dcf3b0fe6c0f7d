#!/bin/sh
# Usage: java_decode_test.sh WRITER CLASSES_DIR TYPES_JAR LCM_JAR TYPE_COUNT
set -e
log=$(mktemp --suffix=.lcmlog)
trap 'rm -f "$log"' EXIT
"$1" "$log"
java -cp "$2:$3:$4" DecodeAll "$log" "$5"
