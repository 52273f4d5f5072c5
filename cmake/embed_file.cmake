# Writes OUTPUT, a C++ source defining `const char* wbm::report_template()` with the
# contents of INPUT (raw string literals in chunks, concatenated by the compiler).
file(READ "${INPUT}" content)
string(LENGTH "${content}" length)
set(chunks "")
set(offset 0)
while(offset LESS length)
  string(SUBSTRING "${content}" ${offset} 16000 piece)
  string(APPEND chunks "R\"wbm_embed(${piece})wbm_embed\"\n")
  math(EXPR offset "${offset} + 16000")
endwhile()
file(WRITE "${OUTPUT}.tmp" "// Generated from ${INPUT}; do not edit.\nnamespace wbm {\nconst char* report_template() {\n  return\n${chunks};\n}\n}  // namespace wbm\n")
file(RENAME "${OUTPUT}.tmp" "${OUTPUT}")
