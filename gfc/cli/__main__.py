from gfc.cli.app import main

main()
