# Warnings are attached to our own targets through an INTERFACE target, never set globally,
# so third-party headers and generated code are not judged by them.
add_library(touchmend_warnings INTERFACE)
target_compile_options(touchmend_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow
                                                    -Wnon-virtual-dtor -Wcast-align -Woverloaded-virtual)
