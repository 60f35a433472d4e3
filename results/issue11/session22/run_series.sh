#!/bin/sh
# The issue-11 series into this folder: session 19's script (same arguments) writing here.
OUT=results/issue11/session22 exec sh "$(dirname "$0")/../session19/run_series.sh" "$@"
