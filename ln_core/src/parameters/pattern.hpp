// The name patterns of ln/parameters/query, query_dict and
// override_dict_single: comma-separated globs where '*' matches any run of
// characters (dots included) and '?' one character; empty globs are
// skipped, so "" matches nothing. Blanks are part of a glob, as in LN 2.9.
//
// LN 2.9 matches '*' without backtracking ("*.mat" misses "ctrl.sub.mat",
// "**" misses everything); here every name the glob describes matches,
// which includes everything LN 2.9 matches.
#pragma once

#include <string_view>

namespace ln::paramcore {

bool glob_match(std::string_view glob, std::string_view name);
/// True if any glob of the comma-separated `patterns` matches `name`.
bool pattern_match(std::string_view patterns, std::string_view name);

}  // namespace ln::paramcore
