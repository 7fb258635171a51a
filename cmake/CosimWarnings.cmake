# One warning policy for every target: cosim_warnings(target).
function(cosim_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow
    -Wnon-virtual-dtor -Wold-style-cast -Wcast-align -Woverloaded-virtual
    -Wdouble-promotion -Wimplicit-fallthrough)
  if(COSIM_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
