//! For tests: a command's arguments as clap parses them from a command line.

pub fn parse<A: clap::Args>(args: &[&str]) -> A {
    use clap::Parser;
    #[derive(clap::Parser)]
    struct Cli<A: clap::Args> {
        #[command(flatten)]
        a: A,
    }
    Cli::<A>::parse_from(std::iter::once("ipmc").chain(args.iter().copied())).a
}
