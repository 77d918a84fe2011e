# ASan + UBSan for the `asan` preset; attached to every touchmend target through this INTERFACE target.
add_library(touchmend_sanitizers INTERFACE)
if(TOUCHMEND_SANITIZE)
  target_compile_options(touchmend_sanitizers INTERFACE -fsanitize=address,undefined
                                                        -fno-omit-frame-pointer -fno-sanitize-recover=all)
  target_link_options(touchmend_sanitizers INTERFACE -fsanitize=address,undefined)
endif()
