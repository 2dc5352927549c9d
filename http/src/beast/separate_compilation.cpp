// Asio and Beast, compiled once for the whole project. Every unit that
// includes them is built with BOOST_ASIO_SEPARATE_COMPILATION and
// BOOST_BEAST_SEPARATE_COMPILATION (the arscout_beast target carries both),
// so it sees declarations only and links their definitions from here,
// instead of compiling Asio's and Beast's non-template code again each time.
#include <utility>  // before Asio, for C++20

#include <boost/asio/impl/src.hpp>
#include <boost/asio/ssl/impl/src.hpp>
#include <boost/beast/src.hpp>
