# The median of numbers sorted ascending on stdin, one a line, for the
# benchmark scripts: ... | sort -g | awk -f tools/median.awk [-v format=%.4g]
# A figure a run could not give (nan, or an empty field) is left out; with
# none left the median is nan. Without a format the middle value is printed
# as it was read (the mean of the two middle ones for an even count).
tolower($1) != "nan" && $1 != "" { x[++n] = $1 }
END {
  if (n == 0) { print "nan"; exit }
  m = (n % 2) ? x[(n + 1) / 2] : (x[n / 2] + x[n / 2 + 1]) / 2
  if (format != "") printf format "\n", m; else print m
}
